"""swazure_ros.files.reading: what a run may take of the machine."""

import subprocess
import sys

# A process of its own under `ulimit -v`: what it may still take, what it takes, its limit.
_UNDER_A_LIMIT = """
import resource
from swazure_ros.files.reading import _address_space, available_memory
limit = 6 * 2**30
resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
used = _address_space()
print(available_memory(), used, limit)
"""


def test_a_process_under_an_address_space_limit_is_told_no_more_than_the_limit_leaves():
    done = subprocess.run(
        [sys.executable, "-c", _UNDER_A_LIMIT], capture_output=True, text=True, check=True
    )
    free, used, limit = map(int, done.stdout.split())
    assert 0 < used < limit
    # The machine's free memory may be more; the limit is what binds (a few MB of slack
    # for what the process mapped between the two readings).
    assert 0 < free <= limit - used + 64 * 2**20
