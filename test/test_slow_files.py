"""The suite's own order: the slow files that run first are files of the suite."""

import pytest

from .conftest import REPO, SLOW_FILES


def test_every_slow_file_that_runs_first_is_a_test_file_of_the_suite():
    # A file renamed or split would drop out of the order silently, and its long tests
    # could end the suite again with one worker idle.
    missing = [name for name in SLOW_FILES if not (REPO / name).is_file()]
    assert missing == [], missing
    assert len(set(SLOW_FILES)) == len(SLOW_FILES)


def test_the_slow_files_run_first_and_each_file_s_tests_together(request: pytest.FixtureRequest):
    items = request.session.items
    if len(items) < 2:
        pytest.skip("one test collected: no order to look at")
    files = [item.path.relative_to(REPO).as_posix() for item in items]
    ranks = [SLOW_FILES.index(name) if name in SLOW_FILES else len(SLOW_FILES) for name in files]
    assert ranks == sorted(ranks)
    # Each file's tests together, so that its module fixtures are set up once.
    runs = [name for number, name in enumerate(files) if number == 0 or files[number - 1] != name]
    assert len(runs) == len(set(runs))
