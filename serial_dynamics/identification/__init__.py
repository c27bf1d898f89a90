"""Identification of the inertial and friction parameters of a serial chain, from an
excitation trajectory to a corrected URDF (docs/identification.md):

    from serial_dynamics import identification as ident
    ex = ident.excitation(robot, duration=20)              # Fourier excitation, min cond
    rec = ident.load_recording("run.csv", robot.joint_names)   # CSV or ROS 2 bag
    res = ident.identify(robot, rec.t, rec.q, rec.tau, rec.qd, source="arm.urdf")
    print(res.summary()); res.write_urdf("identified.urdf")
"""
from .base_parameters import BaseParameters, base_parameters
from .data import Recording, load_recording, read_bag, read_csv, write_bag
from .excitation import Excitation, excitation
from .identify import METHODS, identify
from .result import IdentificationResult, Validation

__all__ = ["BaseParameters", "base_parameters", "Recording", "load_recording", "read_bag",
           "read_csv", "write_bag", "Excitation", "excitation", "METHODS", "identify",
           "IdentificationResult", "Validation"]
