"""python -m serial_dynamics.core: fill the numba cache (``serial_dynamics.precompile``)."""
from serial_dynamics.precompile import main

main()
