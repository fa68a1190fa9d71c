#!/usr/bin/env python3
"""Bring up a swarm of FLS nodes: the same launcher as `swazure spawn` (see --help)."""

import sys

from swazure_ros.cli.main import main

if __name__ == "__main__":
    sys.exit(main(["spawn", *sys.argv[1:]]))
