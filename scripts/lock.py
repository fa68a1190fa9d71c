"""Write requirements.lock from a `pip install --dry-run --report` of requirements.in.

pip freeze cannot be used: the ROS 2 wheels carry metadata names (such as
action_msgs) that differ from their PyPI project names (ros-action-msgs), so
a frozen list does not install. The project name is read from each wheel's
file name instead.

Usage: python scripts/lock.py REPORT.json > requirements.lock
"""

import json
import sys


def main() -> int:
    with open(sys.argv[1]) as handle:
        report = json.load(handle)
    lines = []
    for item in report["install"]:
        filename = item["download_info"]["url"].rsplit("/", 1)[-1]
        project = filename.split("-", 1)[0].replace("_", "-").lower()
        lines.append(f"{project}=={item['metadata']['version']}")
    print("# Generated from requirements.in by 'make lock'; do not edit by hand.")
    print("\n".join(sorted(set(lines))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
