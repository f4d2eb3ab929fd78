"""The robot side: the safety filter between the planner and the robot, the frame guard, the watchdog,
the driver interface and the robot as a plant, a Franka driver over franky-control and a simulated
Franka over franky-sim (docs/robot.md). The Franka parts need ``pip install 'dexpush[franka]'``."""
