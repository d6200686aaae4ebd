//! The crate's message structs against rosbags: `fixtures/cdr_fixtures.json` holds values and
//! the CDR bytes rosbags serialized for them (written by `fixtures/make_cdr_fixtures.py`). Each
//! struct must read those bytes into the same field values and write the same bytes back.

use ros2_robot::cdr;
use ros2_robot::msgs::*;
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::Value;

fn check<T: Serialize + DeserializeOwned>(value: &Value, bytes: &[u8], ros_type: &str) {
    let decoded: T = cdr::from_bytes(bytes).unwrap_or_else(|e| panic!("{ros_type}: {e}"));
    assert_eq!(
        &serde_json::to_value(&decoded).unwrap(),
        value,
        "{ros_type}: field values"
    );
    assert_eq!(
        cdr::to_bytes(&decoded).unwrap(),
        bytes,
        "{ros_type}: bytes written back"
    );
}

fn hex(text: &str) -> Vec<u8> {
    (0..text.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&text[i..i + 2], 16).unwrap())
        .collect()
}

#[test]
fn every_struct_matches_rosbags_bytes() {
    let entries: Vec<Value> = serde_json::from_str(include_str!("fixtures/cdr_fixtures.json"))
        .expect("fixture file is JSON");
    let mut seen = Vec::new();
    for entry in &entries {
        let ros_type = entry["type"].as_str().unwrap();
        let value = &entry["value"];
        let bytes = hex(entry["cdr"].as_str().unwrap());
        match ros_type {
            "trajectory_msgs/msg/JointTrajectory" => {
                check::<JointTrajectory>(value, &bytes, ros_type)
            }
            "sensor_msgs/msg/JointState" => check::<JointState>(value, &bytes, ros_type),
            "std_msgs/msg/Float64" => check::<Float64>(value, &bytes, ros_type),
            "std_msgs/msg/Float64MultiArray" => check::<Float64MultiArray>(value, &bytes, ros_type),
            "geometry_msgs/msg/PointStamped" => check::<PointStamped>(value, &bytes, ros_type),
            "geometry_msgs/msg/PoseStamped" => check::<PoseStamped>(value, &bytes, ros_type),
            "rosgraph_msgs/msg/Clock" => check::<Clock>(value, &bytes, ros_type),
            "control_msgs/action/FollowJointTrajectory_Goal" => {
                check::<FollowJointTrajectoryGoal>(value, &bytes, ros_type)
            }
            "control_msgs/action/FollowJointTrajectory_Result" => {
                check::<FollowJointTrajectoryResult>(value, &bytes, ros_type)
            }
            "control_msgs/action/FollowJointTrajectory_Feedback" => {
                check::<FollowJointTrajectoryFeedback>(value, &bytes, ros_type)
            }
            "action_msgs/msg/GoalInfo" => check::<GoalInfo>(value, &bytes, ros_type),
            "action_msgs/srv/CancelGoal_Request" => {
                check::<CancelGoalRequest>(value, &bytes, ros_type)
            }
            other => panic!("no struct for {other}"),
        }
        seen.push(ros_type);
    }
    assert_eq!(seen.len(), 12, "every struct is checked: {seen:?}");
}
