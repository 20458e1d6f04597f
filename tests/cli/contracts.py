#!/usr/bin/python3
"""The fast rows of scripts/contract_check.py: every flag, JSON key, path and exit code the
project promised to keep stable, run against the real binary and the Python package, so that a
rename that breaks one fails CI (the whole table, slow rows too: scripts/contract_check.py).

usage: contracts.py AMCTL
"""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
import contract_check  # noqa: E402

if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    sys.argv = [sys.argv[0], "--fast", "--amctl", sys.argv[1]]
    sys.exit(contract_check.main())
