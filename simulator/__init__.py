"""riverbridge: simulator (the Unity role of the thesis).

A pure numeric core with numpy arrays in and out, plus one edge module that talks to the
bridge through `clients`:

- `scene.build_scene(cfg) -> Scene`: the thesis river valley (or loaded terrain) as one Embree
  scene with per-triangle materials; `Scene.start_pose` is afloat on the river.
- `dynamics.VesselDynamics`: the 3-DOF surge/sway/yaw model (thesis eq. 2.1.1-2.1.2) with
  collisions; `dynamics.Pose2D`, `VesselState`, `Command`.
- sensors: `lidar.Lidar`, `radar.Radar`, `camera.Camera`, `imu.Imu`, `gnss.Gnss`, each with
  thesis defaults (`config`) and a `.message(..., stamp_ns)` building the canonical ROS dict.
- `node.serve` / `cli.main`: `python -m simulator --bridge ws://127.0.0.1:9090`.
"""
