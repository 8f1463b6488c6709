"""Any arm under ros2_control, moved as a student expects (``servolab arm``): shared robot
machinery, no robot of its own (it has no ``plugin`` module, so the registry lists nothing
here).

- :mod:`.spec`: the arm found in a robot's files (controllers file, MoveIt SRDF and
  joint_limits.yaml, URDF), and how each fact was chosen;
- :mod:`.session`: its controllers reached through their actions, each move timed by ruckig;
- :mod:`.pick`: a pick and place planned by the inverse kinematics and judged by MuJoCo;
- :mod:`.plot`: commanded against measured joints;
- :mod:`.run`: the command's run (bring-up or join, record, judge, summarise).
"""
