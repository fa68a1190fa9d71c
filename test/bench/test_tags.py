"""bench.tags: the swarm key's cost per offer, keyed beside plain."""

from bench import tags


def test_the_tags_section_times_each_offer_keyed_and_plain_and_the_auth_is_48_bytes(monkeypatch):
    monkeypatch.setattr(tags, "TAG_LABELS", (0, 10))
    monkeypatch.setattr(tags, "TAG_REPEATS", 3)
    lines = tags.tags_section(None)
    rows = [line.split("|")[1:-1] for line in lines if line.startswith("| 0 ") or
            line.startswith("| 10 ")]  # fmt: skip
    assert [int(row[0]) for row in rows] == [0, 10]
    for row in rows:
        keyed, plain = int(row[1]), int(row[2])
        assert keyed == plain + 48  # sender, counter, HMAC-SHA256
        assert all(float(cell) > 0 for cell in row[3:7])
