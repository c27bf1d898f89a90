"""What the nodes run between two messages, without ROS: every node's rclpy-free logic in
one place. A node converts its parameters and messages and makes one call here per
callback; tests drive these with their own clock.

    simulator.py    SimulatorLoop: the simulator node's thread and schedule, the lockstep
                    with a controller, commands, ~/step, ~/reset, the report
    pacing.py       Pacer: the simulator's wall-clock pacing
    controller.py   Controller: the computed-torque controller's state, reference, mode,
                    command and report
    observer.py     CollisionMonitor: the external-torque observer's estimate, wrench and
                    collision flag
    progress.py     Heartbeat: a progress line while a start-up step (a cold compile) is slow
"""
