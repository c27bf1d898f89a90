"""serial_dynamics: ament_python package that also installs with plain pip."""
import os
from glob import glob

from setuptools import Extension, find_packages, setup

try:                          # numpy's headers: pyproject.toml's build requirements bring it
    import numpy
except ImportError:           # (a build without them installs without the extension)
    numpy = None

PACKAGE = "serial_dynamics"
NODES = ["simulator", "dynamics", "inverse_dynamics", "computed_torque_controller",
         "external_torque_observer"]

setup(
    name=PACKAGE,
    version="0.1.0",
    # serial_dynamics_interfaces/ is a package of its own (ament_cmake; pip builds it from
    # its pyproject.toml): never part of this one
    packages=find_packages(exclude=["test", "test.*", "bench", "serial_dynamics_interfaces",
                                    "serial_dynamics_interfaces.*"]),
    package_data={PACKAGE: ["builtin/*.urdf"]},
    # single-state entry points called without numba's dispatcher (core/_fastcall.c); optional:
    # without a C compiler the package installs without it and calls through the dispatcher
    ext_modules=[] if numpy is None else [
        Extension(f"{PACKAGE}.core._fastcall", [f"{PACKAGE}/core/_fastcall.c"],
                  include_dirs=[numpy.get_include()], optional=True)],
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (os.path.join("share", PACKAGE, "config"), glob("config/*.yaml")),
        (os.path.join("share", PACKAGE, "launch"), glob("launch/*.py")),
    ],
    python_requires=">=3.10",
    install_requires=["numpy>=1.24", "scipy>=1.10", "yourdfpy>=0.0.56", "numba>=0.59,<0.69",
                      "rosbags>=0.11",    # identification: ROS 2 bags without a ROS install
                      "toppra>=0.6",      # trajectory.time_parameterize (TOPP-RA)
                      "clarabel>=0.9"],   # contacts: forces in friction cones (an SOCP)
    extras_require={
        # Off a ROS install only: rclpy and messages as PyPI wheels (CPython 3.11).
        "ros": [
            "ros-jazzy-rclpy",
            "ros-jazzy-common-interfaces",
            "ros-jazzy-rmw-fastrtps-cpp",
        ],
        "plot": ["matplotlib"],
        # scale-out (serial_dynamics.sweep): Dask's distributed scheduler, tables, Parquet, specs
        "cluster": ["dask[distributed]", "pandas", "pyarrow", "pyyaml"],
        # serial_dynamics.gpu: numba's CUDA target with the CUDA 12 toolkit from PyPI (NVIDIA
        # drivers >= 525; for a CUDA 13 driver, numba-cuda[cu13]). The release the tests ran on.
        "gpu": ["numba-cuda[cu12]==0.30.*"],
        # numba-cuda without a toolkit: the gpu tests run in numba's CUDA simulator
        # pytest-xdist: the suite runs in two workers (setup.cfg)
        "test": ["pytest", "pytest-xdist", "hypothesis", "pin", "example-robot-data",
                 "matplotlib", "mpmath", "numba-cuda==0.30.*"],
        "bench": ["pin", "example-robot-data", "mujoco", "matplotlib"],
    },
    zip_safe=False,
    maintainer="serial_dynamics developers",
    description="Dynamics of serial manipulators from URDF, with ROS 2 nodes",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [f"{node} = {PACKAGE}.ros.{node}:main" for node in NODES]
        + ["serial-dynamics = serial_dynamics.cli:main"],
    },
)
