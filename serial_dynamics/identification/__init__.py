"""Identification of the inertial and friction parameters of a serial chain, from an
excitation trajectory to a corrected URDF (docs/identification.md):

    from serial_dynamics import identification as ident
    ex = ident.excitation(robot, duration=20)              # Fourier excitation, min cond
    rec = ident.load_recording("run.csv", robot.joint_names)   # CSV or ROS 2 bag
    res = ident.identify(robot, rec.t, rec.q, rec.tau, rec.qd, source="arm.urdf")
    print(res.summary()); res.write_urdf("identified.urdf")
    est = ident.estimate_payload(robot, rec.t, rec.q, rec.tau)   # what the tool holds
    held = robot.with_payload(est.mass, est.com, est.inertia)
"""
from .base_parameters import BaseParameters, base_parameters
from .data import Recording, load_recording, read_bag, read_csv, write_bag
from .excitation import Excitation, excitation
from .identify import METHODS, identify
from .payload import PayloadEstimate, estimate_payload
from .result import IdentificationResult, Validation

__all__ = ["BaseParameters", "base_parameters", "Recording", "load_recording", "read_bag",
           "read_csv", "write_bag", "Excitation", "excitation", "METHODS", "identify",
           "PayloadEstimate", "estimate_payload",
           "IdentificationResult", "Validation"]
