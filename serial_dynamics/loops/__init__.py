"""What the controller and observer nodes run between two messages, without ROS: the
computed-torque controller's loop (``controller.Controller``) and the external-torque
observer's (``observer.CollisionMonitor``). A node converts its parameters and messages and
makes one call here per callback; tests drive these with their own clock."""
