"""ROS 2 name resolution and QoS profiles of dmprs.ros2."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from cyclonedds.core import Policy

import dmprs
from dmprs.errors import InvalidInputError
from dmprs.ros2 import ACTION_STATUS, CLOCK, DEFAULT, SENSOR_DATA
from dmprs.ros2.names import resolve, service_dds_names, topic_dds_name


@pytest.mark.parametrize(
    ("name", "namespace", "expected"),
    [
        ("/joint_states", "/robot", "/joint_states"),
        ("joint_states", "/", "/joint_states"),
        ("joint_states", "/robot", "/robot/joint_states"),
        ("arm/commands", "robot", "/robot/arm/commands"),
        ("~", "/robot", "/robot/dmprs"),
        ("~/status", "/", "/dmprs/status"),
        ("~/status", "/robot/left", "/robot/left/dmprs/status"),
    ],
)
def test_names_resolve_as_ros_2_resolves_them(name: str, namespace: str, expected: str) -> None:
    assert resolve(name, namespace, "dmprs") == expected


@pytest.mark.parametrize("name", ["", "a//b", "a/", "1abc", "a__b", "~x", "a b", "é"])
def test_invalid_names_are_refused(name: str) -> None:
    with pytest.raises(InvalidInputError):
        resolve(name, "/", "dmprs")


def test_dds_names_of_topics_and_services() -> None:
    assert topic_dds_name("/joint_states") == "rt/joint_states"
    assert service_dds_names("/c/follow_joint_trajectory/_action/send_goal") == (
        "rq/c/follow_joint_trajectory/_action/send_goalRequest",
        "rr/c/follow_joint_trajectory/_action/send_goalReply",
    )


def test_qos_profiles_are_ros_2_profiles() -> None:
    from cyclonedds.util import duration

    reliable = Policy.Reliability.Reliable(duration(infinite=True))
    xcdr1 = Policy.DataRepresentation(use_cdrv0_representation=True)
    assert {reliable, Policy.Durability.Volatile, Policy.History.KeepLast(10), xcdr1} <= set(DEFAULT.to_cyclone())
    sensor = set(SENSOR_DATA.to_cyclone())
    assert {Policy.Reliability.BestEffort, Policy.Durability.Volatile, Policy.History.KeepLast(5), xcdr1} <= sensor
    assert {Policy.Reliability.BestEffort, Policy.History.KeepLast(1)} <= set(CLOCK.to_cyclone())
    status = set(ACTION_STATUS.to_cyclone())
    assert {reliable, Policy.Durability.TransientLocal, Policy.History.KeepLast(1)} <= status


def test_a_depth_dds_cannot_hold_is_refused_not_taken_modulo_2_32() -> None:
    # Cyclone read a depth of 2**32 + 5 as 5 and 1e20 as 1661992960
    assert Policy.History.KeepLast(2**31 - 1) in set(DEFAULT.with_depth(2**31 - 1).to_cyclone())
    assert Policy.History.KeepAll in set(DEFAULT.with_depth(0).to_cyclone())
    for bad in (2**31, 2**32 + 5, 10**20, -1, 2.5, True):
        with pytest.raises(InvalidInputError, match="depth"):
            DEFAULT.with_depth(bad)  # type: ignore[arg-type]


def test_import_dmprs_leaves_cyclonedds_and_rosbags_alone() -> None:
    code = "import sys, dmprs; print([m for m in ('cyclonedds', 'rosbags', 'dmprs.ros2') if m in sys.modules])"
    package_root = str(Path(dmprs.__file__).parents[1])
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": package_root},
    )
    assert out.stdout.strip() == "[]"


def test_the_domain_is_ros_domain_ids_when_none_is_given(monkeypatch):
    from dmprs.ros2.names import domain_id

    monkeypatch.delenv("ROS_DOMAIN_ID", raising=False)
    assert domain_id() == 0
    monkeypatch.setenv("ROS_DOMAIN_ID", " 42 ")
    assert domain_id() == 42 and domain_id(7) == 7
    for bad in ("233", "-1", "x"):
        monkeypatch.setenv("ROS_DOMAIN_ID", bad)
        with pytest.raises(InvalidInputError, match="ROS_DOMAIN_ID"):
            domain_id()
    for bad in (233, -1, True, 1.5):
        with pytest.raises(InvalidInputError, match="domain_id"):
            domain_id(bad)


def test_a_second_configuration_for_a_joined_domain_is_a_dmprs_error(domain_id):
    from dmprs.errors import AdapterError
    from dmprs.ros2 import LOOPBACK_CONFIG, Node

    with Node("first", domain_id, config=LOOPBACK_CONFIG), pytest.raises(AdapterError, match="joined the domain"):
        Node("second", domain_id, config=LOOPBACK_CONFIG)
