"""Guidance and control: follow the river, keep clear of obstacles, command the thrusters.

The fourth process beside simulator, bridge and navigation (thesis 5.2's future work): it reads
navigation's output and the vessel's odometry through the bridge and publishes
`/guidance/cmd_wrench`. A pure numeric core (`path`, `avoidance`, `control`, `pilot`) and one
edge module (`node`) that talks through `clients`; it never imports bridge, simulator or
navigation.
"""
