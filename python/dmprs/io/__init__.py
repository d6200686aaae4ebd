"""Demonstrations in and trajectories out: ROS bags, LeRobot datasets, CSV and npz files.

The readers import their file-format libraries (``rosbags``, ``pyarrow``) only when called;
install them with ``pip install "dmprs[io]"``. See ``docs/io.md``.
"""

from dmprs.io.lerobot import Episode, read_lerobot
from dmprs.io.poses import PoseTrajectory
from dmprs.io.rosbag import JointRecording, bag_topics, read_joint_states, read_poses, read_tf
from dmprs.io.segment import cut, motion_ranges, resample, split_at_rest

__all__ = [
    "Episode",
    "JointRecording",
    "PoseTrajectory",
    "bag_topics",
    "cut",
    "motion_ranges",
    "read_joint_states",
    "read_lerobot",
    "read_poses",
    "read_tf",
    "resample",
    "split_at_rest",
]
