"""``python -m serial_dynamics.ros.demo``: the demo's command line (``main``)."""
import sys

from . import main

sys.exit(main())
