"""Motion planning for the Nextage's left arm: a plant of robot and bin without the parts, IK
for grasp poses, and joint trajectories within the planning limits, checked for collisions.

- ``planning_model``: the collision-checking plant (robot, gripper, bin; no pile);
- ``grasp_poses``: pre-grasp, grasp, lift and place tool poses from a grasp candidate;
- ``ik``: inverse kinematics for a tool pose, seeded from the current configuration;
- ``trajectory``: rest-to-rest joint-space profiles within velocity and acceleration limits;
- ``arm_motion``: all of it for one pick, behind the ``Motion`` interface the pick planner uses.
"""
