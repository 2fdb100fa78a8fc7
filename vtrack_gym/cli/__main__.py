"""``python -m vtrack_gym.cli``: the ``vtrack`` command."""

import sys

from vtrack_gym.cli import main

sys.exit(main())
