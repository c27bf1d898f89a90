"""python -m serial_dynamics.builtin: (re)write the built-in URDF files."""
from . import write_all

write_all()
