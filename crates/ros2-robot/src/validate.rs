//! The checks a joint_trajectory_controller makes before it takes a trajectory (on its action or
//! its topic): the controller's joints, each once, all of them, and points that are consistent.

use crate::msgs::JointTrajectory;

/// Why `trajectory` cannot run on a controller of `joints`, or `Ok` when it can.
pub fn check_trajectory(trajectory: &JointTrajectory, joints: &[String]) -> Result<(), String> {
    let names = &trajectory.joint_names;
    if names.is_empty() {
        return Err("the trajectory names no joint".into());
    }
    for (i, name) in names.iter().enumerate() {
        if !joints.contains(name) {
            return Err(format!(
                "joint '{name}' is not a joint of this controller ({})",
                joints.join(", ")
            ));
        }
        if names[..i].contains(name) {
            return Err(format!("joint '{name}' is named twice"));
        }
    }
    if names.len() != joints.len() {
        let missing: Vec<&str> = joints
            .iter()
            .filter(|j| !names.contains(j))
            .map(String::as_str)
            .collect();
        return Err(format!(
            "the trajectory leaves out joints {}",
            missing.join(", ")
        ));
    }
    if trajectory.points.is_empty() {
        return Err("the trajectory has no point".into());
    }
    let mut previous: Option<f64> = None;
    for (k, point) in trajectory.points.iter().enumerate() {
        if point.positions.len() != names.len() {
            return Err(format!(
                "point {k} has {} positions for {} joints",
                point.positions.len(),
                names.len()
            ));
        }
        for (field, values) in [
            ("velocities", &point.velocities),
            ("accelerations", &point.accelerations),
            ("effort", &point.effort),
        ] {
            if !values.is_empty() && values.len() != names.len() {
                return Err(format!(
                    "point {k} has {} {field} for {} joints",
                    values.len(),
                    names.len()
                ));
            }
        }
        if point
            .positions
            .iter()
            .chain(&point.velocities)
            .chain(&point.accelerations)
            .any(|v| !v.is_finite())
        {
            return Err(format!("point {k} has a non-finite value"));
        }
        let t = point.time_from_start.seconds();
        if previous.is_some_and(|p| t <= p) {
            return Err(format!("point {k}'s time_from_start does not increase"));
        }
        previous = Some(t);
    }
    Ok(())
}

/// A checked trajectory as arrays in the controller's joint order.
#[derive(Clone, Debug, PartialEq)]
pub struct TrajectoryArrays {
    /// The header stamp (s): when the trajectory starts; 0 means as soon as it arrives.
    pub stamp: f64,
    /// Each point's time_from_start in seconds.
    pub times: Vec<f64>,
    /// One row per point, one column per controller joint.
    pub positions: Vec<Vec<f64>>,
    /// Present only when every point has velocities.
    pub velocities: Option<Vec<Vec<f64>>>,
    /// Present only when every point has accelerations.
    pub accelerations: Option<Vec<Vec<f64>>>,
}

/// The arrays of a trajectory that passed [`check_trajectory`] for `joints`.
pub fn controller_order(trajectory: &JointTrajectory, joints: &[String]) -> TrajectoryArrays {
    let column: Vec<usize> = joints
        .iter()
        .map(|j| {
            trajectory
                .joint_names
                .iter()
                .position(|n| n == j)
                .expect("checked trajectory names every joint")
        })
        .collect();
    let reorder = |values: &Vec<f64>| column.iter().map(|&c| values[c]).collect::<Vec<f64>>();
    let all = |field: fn(&crate::msgs::JointTrajectoryPoint) -> &Vec<f64>| {
        trajectory
            .points
            .iter()
            .all(|p| !field(p).is_empty())
            .then(|| {
                trajectory
                    .points
                    .iter()
                    .map(|p| reorder(field(p)))
                    .collect()
            })
    };
    TrajectoryArrays {
        stamp: trajectory.header.stamp.seconds(),
        times: trajectory
            .points
            .iter()
            .map(|p| p.time_from_start.seconds())
            .collect(),
        positions: trajectory
            .points
            .iter()
            .map(|p| reorder(&p.positions))
            .collect(),
        velocities: all(|p| &p.velocities),
        accelerations: all(|p| &p.accelerations),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::{Duration, JointTrajectoryPoint};

    fn joints() -> Vec<String> {
        vec!["a".into(), "b".into()]
    }

    fn trajectory(names: &[&str], points: &[(f64, Vec<f64>)]) -> JointTrajectory {
        JointTrajectory {
            joint_names: names.iter().map(|n| n.to_string()).collect(),
            points: points
                .iter()
                .map(|(t, q)| JointTrajectoryPoint {
                    positions: q.clone(),
                    time_from_start: Duration::from_seconds(*t),
                    ..Default::default()
                })
                .collect(),
            ..Default::default()
        }
    }

    #[test]
    fn a_full_increasing_trajectory_in_any_joint_order_passes() {
        let t = trajectory(&["b", "a"], &[(0.5, vec![1.0, 2.0]), (1.0, vec![0.0, 0.0])]);
        assert_eq!(check_trajectory(&t, &joints()), Ok(()));
    }

    #[test]
    fn arrays_come_in_the_controllers_joint_order() {
        let mut t = trajectory(&["b", "a"], &[(0.5, vec![1.0, 2.0]), (1.0, vec![3.0, 4.0])]);
        t.points[0].velocities = vec![0.1, 0.2];
        let arrays = controller_order(&t, &joints());
        assert_eq!(arrays.times, vec![0.5, 1.0]);
        assert_eq!(arrays.positions, vec![vec![2.0, 1.0], vec![4.0, 3.0]]);
        assert_eq!(arrays.velocities, None);
        t.points[1].velocities = vec![0.3, 0.4];
        assert_eq!(
            controller_order(&t, &joints()).velocities,
            Some(vec![vec![0.2, 0.1], vec![0.4, 0.3]])
        );
    }

    #[test]
    fn each_defect_is_named() {
        let cases = [
            (
                trajectory(&["a", "c"], &[(1.0, vec![0.0, 0.0])]),
                "'c' is not a joint",
            ),
            (
                trajectory(&["a", "a"], &[(1.0, vec![0.0, 0.0])]),
                "named twice",
            ),
            (
                trajectory(&["a"], &[(1.0, vec![0.0])]),
                "leaves out joints b",
            ),
            (trajectory(&["a", "b"], &[]), "no point"),
            (
                trajectory(&["a", "b"], &[(1.0, vec![0.0])]),
                "1 positions for 2 joints",
            ),
            (
                trajectory(&["a", "b"], &[(1.0, vec![0.0, 0.0]), (1.0, vec![0.0, 0.0])]),
                "does not increase",
            ),
            (
                trajectory(&["a", "b"], &[(1.0, vec![f64::NAN, 0.0])]),
                "non-finite",
            ),
        ];
        for (t, expected) in cases {
            let err = check_trajectory(&t, &joints()).unwrap_err();
            assert!(
                err.contains(expected),
                "{err:?} should contain {expected:?}"
            );
        }
    }
}
