"""Demonstrations in and trajectories out: ROS bags, LeRobot datasets, CSV and npz files.

The readers import their file-format libraries (``rosbags``, ``pyarrow``) only when called;
install them with ``pip install "dmprs[io]"``. See ``docs/io.md``.
"""

from dmprs.io.export import write_joint_trajectory_bag, write_trajectory_csv
from dmprs.io.importer import ImportedDemo, build_database, load_demos
from dmprs.io.lerobot import Episode, read_lerobot
from dmprs.io.poses import pose_trajectory, poses_between, resample_poses, split_poses_at_rest
from dmprs.io.rosbag import JointRecording, bag_topics, read_joint_states, read_poses, read_tf
from dmprs.io.segment import cut, motion_ranges, resample, split_at_rest
from dmprs.io.tables import QueryTable, read_csv_trajectory, read_npz_trajectory, read_query_table

__all__ = [
    "Episode",
    "ImportedDemo",
    "JointRecording",
    "QueryTable",
    "bag_topics",
    "build_database",
    "cut",
    "load_demos",
    "motion_ranges",
    "pose_trajectory",
    "poses_between",
    "read_csv_trajectory",
    "read_joint_states",
    "read_lerobot",
    "read_npz_trajectory",
    "read_poses",
    "read_query_table",
    "read_tf",
    "resample",
    "resample_poses",
    "split_at_rest",
    "split_poses_at_rest",
    "write_joint_trajectory_bag",
    "write_trajectory_csv",
]
