"""The demo on a full ROS 2 install: ros2 launch serial_dynamics demo.launch.py

Starts the simulator (publishing /clock, paused at the first waypoint, in lockstep with
its controller: docs/ros.md, "Lockstep") and the
computed-torque controller (on simulated time) with the parameter files of
config/, then runs the demo's trajectory and report against them
(python3 -m serial_dynamics.ros.demo --attach); the launch ends when the demo does.
In the virtual environment, without ros2 launch, `serial-dynamics demo` does the same.

Arguments:
  robot_state_publisher:=true  also start robot_state_publisher with the UR5e URDF: the
                               nodes then take the robot from its robot_description
                               topic, and RViz can show the arm (fixed frame base_link).
  real_time_factor:=1.0        simulated s per wall s (> 0)
"""
import os
import sys

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, EmitEvent, ExecuteProcess, RegisterEventHandler
from launch.conditions import IfCondition
from launch.event_handlers import OnProcessExit
from launch.events import Shutdown
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

from serial_dynamics.builtin import builtin_path
from serial_dynamics.ros.demo.session import LOCKSTEP
from serial_dynamics.trajectory import UR5E_PICK_AND_PLACE


def generate_launch_description():
    config = os.path.join(get_package_share_directory("serial_dynamics"), "config")
    with open(builtin_path("ur5e")) as fh:
        urdf = fh.read()
    with_rsp = LaunchConfiguration("robot_state_publisher")
    demo = ExecuteProcess(cmd=[sys.executable, "-m", "serial_dynamics.ros.demo", "--attach",
                               "--real-time-factor", LaunchConfiguration("real_time_factor")],
                          output="screen")
    return LaunchDescription([
        DeclareLaunchArgument("robot_state_publisher", default_value="false",
                              description="also start robot_state_publisher (UR5e)"),
        DeclareLaunchArgument("real_time_factor", default_value="1.0",
                              description="simulated s per wall s (> 0)"),
        Node(package="robot_state_publisher", executable="robot_state_publisher",
             parameters=[{"robot_description": ParameterValue(urdf, value_type=str)}],
             condition=IfCondition(with_rsp), output="screen"),
        Node(package="serial_dynamics", executable="simulator", name="simulator",
             output="screen",
             parameters=[os.path.join(config, "simulator.yaml"), {
                 "publish_clock": True, "start_paused": True, "lockstep": LOCKSTEP,
                 "initial_positions": UR5E_PICK_AND_PLACE[0][1],
                 "real_time_factor": ParameterValue(LaunchConfiguration("real_time_factor"),
                                                    value_type=float)}]),
        Node(package="serial_dynamics", executable="computed_torque_controller",
             name="computed_torque_controller", output="screen",
             parameters=[os.path.join(config, "computed_torque_controller.yaml"),
                         {"use_sim_time": True, "lockstep": True}]),
        demo,
        RegisterEventHandler(OnProcessExit(target_action=demo,
                                           on_exit=[EmitEvent(event=Shutdown(reason="demo done"))])),
    ])
