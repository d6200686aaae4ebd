//! Online execution of a [`CartesianDmp`] one control period at a time: the counterpart of
//! [`crate::stepper::Stepper`] for a pose (docs/method.md §2.5, docs/cartesian.md).
//!
//! Without measurements, couplings, limits or goal changes, the k-th call returns sample k of
//! [`CartesianDmp::rollout`] bit for bit: the rollout is this stepper run open loop
//! ([`crate::cartesian_rollout`]). Each period updates the position as the discrete DMP does,
//! then `q <- exp(dt/(2 tau) eta) * q`, then the phase; when `dt` is beyond explicit Euler's
//! stability limit the period is split into the joint rollout's sub-steps.
//!
//! The six coordinates of the phase stopping, the limits and the coupling terms are those of the
//! underlying DMP: x, y, z (units of position), then the three of the orientation (rad): the
//! scaled velocity `z = tau [v, omega]`. A measured pose's error is its position difference and
//! its rotation vector `2 log(q~ * conj(q))`. The goal filter moves the goal position as the
//! joint stepper does and the goal orientation along the geodesic,
//! `g_o <- exp(alpha_g h / tau * log(g_new * conj(g_o))) * g_o`. Position limits (a box) and
//! sphere obstacles ([`crate::coupling`]) act on the position.

use crate::cartesian::{CartesianDmp, POSE_WIDTH, UNIT_TOLERANCE, moving_goal};
use crate::coupling::{
    OBSTACLE_PUSH_MAX, OBSTACLE_SPEED_UP_MAX, ObstacleGains, PositionLimits, SphereObstacle,
};
use crate::dmp::{DmpConfig, phase_clock, phase_to_go};
use crate::error::{Error, Result, fmt_g};
use crate::euler::{MAX_SUBSTEPS, moving_spring};
use crate::forcing::{Forcing, SumStart, padded};
use crate::quaternion::{self, Quaternion};
use crate::stepper::{
    Clock, StepperOptions, acceleration_at, check_coordinates, check_state, implicit_step,
    moving_start_refused, position_limits,
};

/// The coordinates of the underlying DMP: x, y, z, then the three of the orientation.
const N: usize = 6;
/// With obstacles, sub-steps are added until `h / tau` times the field's rate is at most this
/// (explicit Euler is stable on a velocity-dependent term only below 2).
const OBSTACLE_STEP: f64 = 0.5;
/// An orientation within this angle (rad) of its filtered target is set to it.
const GOAL_SNAP: f64 = 1e-12;

/// A sample of a Cartesian rollout's arrays, to be written (3 values each, 4 for the
/// quaternion).
pub(crate) struct CartesianRows<'a> {
    pub position: &'a mut [f64],
    pub quaternion: &'a mut [f64],
    pub velocity: &'a mut [f64],
    pub acceleration: &'a mut [f64],
    pub angular_velocity: &'a mut [f64],
    pub angular_acceleration: &'a mut [f64],
}

/// The options of a [`CartesianStepper`]: those of the joint stepper over the six coordinates
/// (position limits over the three of the position), and obstacles.
#[derive(Debug, Clone, PartialEq)]
pub struct CartesianStepperOptions {
    pub base: StepperOptions,
    pub obstacles: Vec<SphereObstacle>,
    pub obstacle_gains: ObstacleGains,
}

impl CartesianStepperOptions {
    pub fn new(dt: f64) -> Self {
        Self {
            base: StepperOptions::new(dt),
            obstacles: Vec::new(),
            obstacle_gains: ObstacleGains::default(),
        }
    }
}

/// A unit quaternion from a caller, checked as [`CartesianDmp::new`] checks its poses.
fn unit(name: &'static str, q: &[f64]) -> Result<Quaternion> {
    let q = [q[0], q[1], q[2], q[3]];
    let n = quaternion::norm(&q);
    if (n - 1.0).abs() > UNIT_TOLERANCE {
        return Err(Error::Quaternion {
            name,
            index: 0,
            value: format!("[{}, {}, {}, {}]", q[0], q[1], q[2], q[3]),
            norm: n,
            requirement: "orientations must be unit quaternions (|norm - 1| <= 1e-6)",
        });
    }
    Ok(if (n - 1.0).abs() <= 1e-15 {
        q
    } else {
        q.map(|c| c / n)
    })
}

pub(crate) fn check_pose(name: &'static str, pose: &[f64]) -> Result<Quaternion> {
    check_coordinates(name, pose, POSE_WIDTH)?;
    unit(name, &pose[3..])
}

/// That no sphere of `obstacles` holds the position `p` (`what` of the movement): the field is
/// not defined inside a sphere, and a movement that starts or ends in one cannot avoid it.
/// The error names `name`, the argument that brought the conflict.
fn check_outside(
    name: &'static str,
    what: &str,
    p: &[f64; 3],
    obstacles: &[SphereObstacle],
) -> Result<()> {
    let Some(i) = obstacles.iter().position(|o| o.holds(p)) else {
        return Ok(());
    };
    let o = &obstacles[i];
    let sphere = format!(
        "obstacles[{i}] (centre [{}, {}, {}], radius {})",
        fmt_g(o.center[0]),
        fmt_g(o.center[1]),
        fmt_g(o.center[2]),
        fmt_g(o.radius)
    );
    let point = format!("[{}, {}, {}]", fmt_g(p[0]), fmt_g(p[1]), fmt_g(p[2]));
    Err(Error::InvalidParameter {
        name,
        // Worded after what the caller just gave: new spheres, or a new position in one.
        value: if name == "obstacles" {
            format!("{sphere}, around the {what} {point}")
        } else {
            format!("{point}, inside {sphere}")
        },
        requirement: "the start, the goal and the current position must be outside every \
                      obstacle (clearance > 0): the field cannot push a movement out of a \
                      sphere, only keep one from entering it",
    })
}

/// Executes a [`CartesianDmp`] one control period at a time (module docs).
#[derive(Debug, Clone)]
pub struct CartesianStepper {
    dmp: CartesianDmp,
    cfg: DmpConfig,
    clock: Clock,
    limits: Option<PositionLimits>,
    obstacles: Vec<SphereObstacle>,
    obstacle_gains: ObstacleGains,
    rest_tol: f64,
    /// Whether the CPU runs [`CartesianStepper::step_avx2`]: detected once, not at every step.
    avx2: bool,
    max_w: f64,
    forcing: Forcing,
    // The state that the next call outputs.
    x: f64,
    p: [f64; 3],
    q: Quaternion,
    /// `tau [v, omega]`.
    z: [f64; N],
    goal_p: [f64; 3],
    goal_q: Quaternion,
    target_p: [f64; 3],
    target_q: Quaternion,
    goal_moving: bool,
    /// The final velocity per unit of scaled time, `tau [v, omega_g]` with the DMP's tau
    /// (docs/cartesian.md, "A final velocity"); `None` for zero.
    final_velocity: Option<[f64; N]>,
    /// `f(x)`, padded as the forcing term writes it.
    f: [f64; padded(N)],
    /// Half the rotation vector from the current orientation to the (unmoving) goal, `log(g_o *
    /// conj(q))`, as the last derivative found it: the rest test's too.
    to_goal: [f64; 3],
    h: [f64; N],
    stiffness: [f64; 3],
    user: [f64; N],
    // The last sample returned.
    out_pose: [f64; POSE_WIDTH],
    out_velocity: [f64; N],
    out_acceleration: [f64; N],
    out_x: f64,
    out_tau: f64,
    at_rest: bool,
    /// Whether the last command rests away from the goal (see [`CartesianStepper::blocked`]).
    blocked: bool,
    /// Whether the last command's acceleration exceeds a limit.
    over_limit: bool,
    steps: u64,
}

impl CartesianStepper {
    pub fn new(dmp: &CartesianDmp, opts: &CartesianStepperOptions) -> Result<Self> {
        let cfg = *dmp.config();
        let clock = Clock::new(&cfg, dmp.tau(), N, &opts.base)?;
        let limits = position_limits(&opts.base, 3, &cfg)?;
        opts.obstacle_gains.validate()?;
        for (i, o) in opts.obstacles.iter().enumerate() {
            o.validate(i)?;
        }
        let goal = dmp.goal();
        check_outside(
            "obstacles",
            "goal",
            &[goal[0], goal[1], goal[2]],
            &opts.obstacles,
        )?;
        let start = dmp.start();
        check_outside(
            "obstacles",
            "start",
            &[start[0], start[1], start[2]],
            &opts.obstacles,
        )?;
        let w = dmp.weights();
        let goal = dmp.goal();
        let mut s = Self {
            dmp: dmp.clone(),
            cfg,
            clock,
            limits,
            obstacles: opts.obstacles.clone(),
            obstacle_gains: opts.obstacle_gains,
            rest_tol: opts.base.rest_tol,
            avx2: crate::linalg::has_avx2_fma(),
            max_w: w.iter().fold(0.0f64, |m, w| m.max(w.abs())),
            forcing: Forcing::new(dmp.basis(), w, SumStart::Zero),
            x: 1.0,
            p: [0.0; 3],
            q: quaternion::IDENTITY,
            z: [0.0; N],
            goal_p: [goal[0], goal[1], goal[2]],
            goal_q: dmp.goal_quaternion(),
            target_p: [goal[0], goal[1], goal[2]],
            target_q: dmp.goal_quaternion(),
            goal_moving: false,
            final_velocity: dmp.final_velocity().map(|v| v.map(|c| c * dmp.tau())),
            f: [0.0; padded(N)],
            to_goal: [0.0; 3],
            h: [0.0; N],
            stiffness: [0.0; 3],
            user: [0.0; N],
            out_pose: [0.0; POSE_WIDTH],
            out_velocity: [0.0; N],
            out_acceleration: [0.0; N],
            out_x: 1.0,
            out_tau: dmp.tau(),
            at_rest: false,
            blocked: false,
            over_limit: false,
            steps: 0,
        };
        s.reset(None)?;
        Ok(s)
    }

    /// Back to the start of a movement from the pose `start` (default: the DMP's start) at rest,
    /// phase 1, towards the current goal. The start quaternion is taken on the side of the DMP's.
    pub fn reset(&mut self, start: Option<&[f64]>) -> Result<()> {
        let start = match start {
            Some(s) => {
                let q = check_pose("start", s)?;
                let q = quaternion::same_hemisphere(&q, &self.dmp.start_quaternion());
                [s[0], s[1], s[2], q[0], q[1], q[2], q[3]]
            }
            None => self.dmp.start(),
        };
        if let Some(lim) = &self.limits
            && let Some(d) = lim.contains(&start[..3])
        {
            return Err(Error::InvalidParameter {
                name: "start",
                value: format!("{} at [{d}]", fmt_g(start[d])),
                requirement: "must be strictly inside position_min and position_max",
            });
        }
        check_outside(
            "start",
            "start",
            &[start[0], start[1], start[2]],
            &self.obstacles,
        )?;
        self.p = [start[0], start[1], start[2]];
        self.q = [start[3], start[4], start[5], start[6]];
        self.z = [0.0; N];
        self.x = 1.0;
        self.goal_p = self.target_p;
        self.goal_q = self.target_q;
        self.goal_moving = false;
        self.forcing.restart();
        self.update_forcing();
        let nominal = self.clock.nominal;
        self.clock.tau = nominal;
        if self.clock.coupling.is_some() {
            self.h = self.derivative(false);
            let tc = self.clock.coupling.as_mut().expect("checked");
            self.clock.tau = tc.tau_at_rest(nominal, &self.h);
        }
        self.out_pose = start;
        self.out_velocity = [0.0; N];
        self.out_acceleration = [0.0; N];
        self.out_x = 1.0;
        self.out_tau = self.clock.tau;
        self.at_rest = false;
        self.blocked = false;
        self.over_limit = false;
        self.steps = 0;
        Ok(())
    }

    /// Starts this movement where `from`'s integrator has arrived, in motion: its position and
    /// orientation, its linear velocity as `z = tau v` and its angular velocity as
    /// `eta = tau omega` (this movement's tau), and `from`'s last command as this one's, against
    /// which phase stopping measures the robot (docs/method.md §2.9). The quaternion keeps
    /// `from`'s sign, so the commanded one runs on without a jump; the goal is taken on the side
    /// that makes `log(g_o * conj(q))` what a reset to this pose gives, so the movement turns
    /// the way its DMP does. Refused with velocity or acceleration limits, as
    /// [`crate::stepper::Stepper`]'s.
    pub(crate) fn take_over(&mut self, from: &CartesianStepper) -> Result<()> {
        if self.clock.coupling.is_some() {
            return Err(moving_start_refused());
        }
        // The goal on its DMP goal's side first, so that repeated hand-overs (a sequence
        // reset and run again) start from the same goal sign.
        self.target_q = quaternion::same_hemisphere(&self.target_q, &self.dmp.goal_quaternion());
        let (p, q) = (from.p, from.q);
        self.reset(Some(&[p[0], p[1], p[2], q[0], q[1], q[2], q[3]]))?;
        if quaternion::dot(&self.q, &q) < 0.0 {
            // `reset` took the start on its DMP start's side; turn the goal with it instead.
            self.q = q;
            self.goal_q = self.goal_q.map(|c| -c);
            self.target_q = self.target_q.map(|c| -c);
        }
        let (tau, inv_from) = (self.clock.tau, 1.0 / from.clock.tau);
        for (z, zf) in self.z.iter_mut().zip(&from.z) {
            *z = zf * inv_from * tau;
        }
        self.out_pose = from.out_pose;
        self.out_velocity = from.out_velocity;
        self.out_acceleration = from.out_acceleration;
        Ok(())
    }

    /// The phase the next step starts from (the last command's is [`CartesianStepper::phase`]).
    pub(crate) fn next_phase(&self) -> f64 {
        self.x
    }

    /// The tolerance of [`CartesianStepper::done`].
    pub(crate) fn rest_tol(&self) -> f64 {
        self.rest_tol
    }

    /// A new goal pose, filtered or at once; its quaternion is taken on the side of the current
    /// goal's, so the sign a caller passes cannot turn the movement into the long way round.
    pub fn set_goal(&mut self, goal: &[f64]) -> Result<()> {
        let q = check_pose("goal", goal)?;
        check_outside(
            "goal",
            "goal",
            &[goal[0], goal[1], goal[2]],
            &self.obstacles,
        )?;
        self.target_p = [goal[0], goal[1], goal[2]];
        self.target_q = quaternion::same_hemisphere(&q, &self.target_q);
        if self.clock.goal_filter.is_none() {
            self.goal_p = self.target_p;
            self.goal_q = self.target_q;
        }
        self.goal_moving = self.goal_p != self.target_p || self.goal_q != self.target_q;
        Ok(())
    }

    /// A new nominal tau (s), from the next period on.
    pub fn set_tau(&mut self, tau: f64) -> Result<()> {
        self.clock.set_nominal(&self.cfg, tau)
    }

    /// Replaces the obstacles (their number may change; this allocates, `step` does not). A
    /// sphere holding the goal or the current position is refused, the obstacles unchanged.
    pub fn set_obstacles(&mut self, obstacles: &[SphereObstacle]) -> Result<()> {
        for (i, o) in obstacles.iter().enumerate() {
            o.validate(i)?;
        }
        check_outside("obstacles", "goal", &self.target_p, obstacles)?;
        check_outside("obstacles", "current position", &self.p, obstacles)?;
        self.obstacles.clear();
        self.obstacles.extend_from_slice(obstacles);
        Ok(())
    }

    /// One control period: returns this period's command, `(pose, [v, omega], [a, omegadot])`
    /// (pose `[x, y, z, qw, qx, qy, qz]`, angular quantities in the world frame), and advances
    /// the state by `dt`. `measured` (the robot's pose) turns on phase stopping.
    pub fn step(
        &mut self,
        measured: Option<&[f64]>,
    ) -> Result<(&[f64; POSE_WIDTH], &[f64; N], &[f64; N])> {
        self.step_coupled(measured, None)
    }

    /// [`CartesianStepper::step`] with a coupling term `C` (6 values: position, then orientation)
    /// added to `tau dz/dt` for this period.
    pub fn step_coupled(
        &mut self,
        measured: Option<&[f64]>,
        coupling: Option<&[f64]>,
    ) -> Result<(&[f64; POSE_WIDTH], &[f64; N], &[f64; N])> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: the CPU supports the enabled features (detected in `new`).
            unsafe { self.period_avx2(measured, coupling) }?;
        } else {
            self.period(measured, coupling)?;
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.period(measured, coupling)?;
        self.check_finite()?;
        Ok((&self.out_pose, &self.out_velocity, &self.out_acceleration))
    }

    /// One period without a measurement or a coupling term, its command copied into a sample
    /// of a rollout's arrays (`t` aside): the Cartesian rollout's sample, by the stepper's own
    /// code. The state is not checked: a rollout checks what it returns.
    pub(crate) fn step_into(&mut self, sample: CartesianRows<'_>) -> Result<()> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: the CPU supports the enabled features (detected in `new`).
            unsafe { self.period_avx2(None, None) }?;
        } else {
            self.period(None, None)?;
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.period(None, None)?;
        let (pose, v, a) = (&self.out_pose, &self.out_velocity, &self.out_acceleration);
        sample.position.copy_from_slice(&pose[..3]);
        sample.quaternion.copy_from_slice(&pose[3..]);
        sample.velocity.copy_from_slice(&v[..3]);
        sample.angular_velocity.copy_from_slice(&v[3..]);
        sample.acceleration.copy_from_slice(&a[..3]);
        sample.angular_acceleration.copy_from_slice(&a[3..]);
        Ok(())
    }

    /// [`CartesianStepper::period`] compiled for AVX2 (same bits: no fused multiply-adds).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn period_avx2(
        &mut self,
        measured: Option<&[f64]>,
        coupling: Option<&[f64]>,
    ) -> Result<()> {
        self.period(measured, coupling)
    }

    /// One period: the command of this period into the last command, the state advanced.
    #[inline(always)]
    fn period(&mut self, measured: Option<&[f64]>, coupling: Option<&[f64]>) -> Result<()> {
        let factor = match measured {
            Some(m) => {
                let q = check_pose("measured", m)?;
                let out_q = [
                    self.out_pose[3],
                    self.out_pose[4],
                    self.out_pose[5],
                    self.out_pose[6],
                ];
                let q = quaternion::same_hemisphere(&q, &out_q);
                let r = quaternion::log(&quaternion::product(&q, &quaternion::conjugate(&out_q)));
                let errors = (0..3)
                    .map(|d| m[d] - self.out_pose[d])
                    .chain(r.iter().map(|r| 2.0 * r));
                self.clock.stop_factor(errors)?
            }
            None => 1.0,
        };
        let coupled = coupling.is_some();
        if let Some(c) = coupling {
            check_coordinates("coupling", c, N)?;
            self.user.copy_from_slice(c);
        }
        let target = if factor == 1.0 {
            self.clock.nominal
        } else {
            self.clock.nominal * factor
        };
        // This period's scale was chosen by the last step; this step chooses the next one's.
        let tau = self.clock.tau;
        let inv_tau = 1.0 / tau;
        self.h = self.derivative(coupled);
        let obstacle_rate = self.obstacle_rate();
        self.at_rest = self.rest();
        self.blocked = !self.at_rest && self.stalled();
        self.out_x = self.x;
        self.out_tau = tau;
        self.out_pose = [
            self.p[0], self.p[1], self.p[2], self.q[0], self.q[1], self.q[2], self.q[3],
        ];
        for d in 0..N {
            self.out_velocity[d] = self.z[d] * inv_tau;
        }
        let (z_k, h_k) = (self.z, self.h);
        self.integrate(inv_tau, coupled, obstacle_rate);
        let next = if self.clock.coupling.is_some() {
            let limits_acceleration = self
                .clock
                .coupling
                .as_ref()
                .is_some_and(|tc| tc.limits_acceleration());
            let h_next = if limits_acceleration {
                self.derivative(coupled)
            } else {
                [0.0; N]
            };
            let nominal = self.clock.nominal;
            let tc = self.clock.coupling.as_mut().expect("checked");
            tc.next_tau(
                tau,
                nominal,
                target,
                &z_k,
                &h_k,
                &self.z,
                &h_next,
                self.clock.dt,
            )
        } else {
            target
        };
        self.clock.tau = next;
        let taud = self.clock.rate(tau, next);
        let inv_next = 1.0 / next;
        for d in 0..N {
            self.out_acceleration[d] = acceleration_at(h_k[d], z_k[d], taud, inv_tau, inv_next);
        }
        self.over_limit = self
            .clock
            .coupling
            .as_ref()
            .is_some_and(|tc| tc.exceeded(&self.out_acceleration));
        self.steps += 1;
        Ok(())
    }

    /// The rate of the obstacles' field at the current state (0 without obstacles), by which
    /// `integrate` splits the period.
    #[inline(always)]
    fn obstacle_rate(&self) -> f64 {
        let mut rate = 0.0f64;
        let zp = [self.z[0], self.z[1], self.z[2]];
        let bound = self.push_bound(&zp);
        let mut scratch = [0.0; 3];
        for o in &self.obstacles {
            rate = rate.max(o.add_repulsion(
                &self.obstacle_gains,
                &self.p,
                &zp,
                bound,
                self.speed_up(),
                &mut scratch,
            ));
        }
        rate
    }

    /// The most by which the obstacles' field may lengthen `z` ([`OBSTACLE_SPEED_UP_MAX`]).
    #[inline(always)]
    fn speed_up(&self) -> f64 {
        OBSTACLE_SPEED_UP_MAX * self.cfg.alpha_z
    }

    /// The bound on the obstacles' push at scaled velocity `zp` ([`OBSTACLE_PUSH_MAX`]).
    #[inline(always)]
    fn push_bound(&self, zp: &[f64; 3]) -> f64 {
        OBSTACLE_PUSH_MAX
            * self.cfg.alpha_z
            * (zp[0] * zp[0] + zp[1] * zp[1] + zp[2] * zp[2]).sqrt()
    }

    /// Integrates one period at time scale `1 / inv_tau` from the current state, whose
    /// derivative is `self.h`, one Cartesian rollout step per sub-step.
    // Index loops over the coordinates, as the rollout writes them (several arrays per index).
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn integrate(&mut self, inv_tau: f64, coupled: bool, obstacle_rate: f64) {
        let cfg = self.cfg;
        let mut substeps = self.clock.substeps;
        if obstacle_rate > 0.0 {
            let needed = (self.clock.dt * inv_tau * obstacle_rate / OBSTACLE_STEP).ceil();
            // Capped: beyond it the field is far stiffer than any sensible gain makes it.
            substeps = substeps.max(needed.min(MAX_SUBSTEPS as f64) as usize);
        }
        let hs = self.clock.dt / substeps as f64;
        let a = hs * inv_tau;
        let half_step = 0.5 * hs * inv_tau;
        for sub in 0..substeps {
            let h = if sub == 0 {
                self.h
            } else {
                self.update_forcing();
                self.derivative(coupled)
            };
            let turn = quaternion::exp(&[self.z[3], self.z[4], self.z[5]].map(|c| c * half_step));
            for d in 0..3 {
                if self.stiffness[d] == 0.0 {
                    let dz = h[d] * inv_tau;
                    self.p[d] += self.z[d] * inv_tau * hs;
                    self.z[d] += dz * hs;
                } else {
                    let (dp, dz) = implicit_step(&cfg, self.stiffness[d], a, self.z[d], h[d]);
                    self.p[d] += dp;
                    self.z[d] += dz;
                }
            }
            for (eta, h) in self.z[3..].iter_mut().zip(&h[3..]) {
                let deta = h * inv_tau;
                *eta += deta * hs;
            }
            self.q = quaternion::renormalize(&quaternion::product(&turn, &self.q));
            self.x -= cfg.alpha_x * self.x * inv_tau * hs;
            if self.goal_moving {
                self.filter_goal(a);
            }
        }
        self.update_forcing();
    }

    /// One Euler step of the goal filter over `a` of scaled time (module docs).
    fn filter_goal(&mut self, a: f64) {
        let alpha_g = self
            .clock
            .goal_filter
            .expect("a goal moves only when filtered");
        let mut settled = true;
        for d in 0..3 {
            let gap = self.target_p[d] - self.goal_p[d];
            if gap.abs() <= 1e-12 * self.target_p[d].abs().max(1.0) {
                self.goal_p[d] = self.target_p[d];
            } else {
                self.goal_p[d] += alpha_g * gap * a;
                settled = false;
            }
        }
        let r = quaternion::log(&quaternion::product(
            &self.target_q,
            &quaternion::conjugate(&self.goal_q),
        ));
        if (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt() <= GOAL_SNAP {
            self.goal_q = self.target_q;
        } else {
            let turn = quaternion::exp(&r.map(|c| c * alpha_g * a));
            self.goal_q = quaternion::renormalize(&quaternion::product(&turn, &self.goal_q));
            settled = false;
        }
        self.goal_moving = !settled;
    }

    /// `self.f = f(x)` (eq. 4).
    #[inline(always)]
    fn update_forcing(&mut self) {
        let x = self.forcing_phase();
        self.forcing.eval(x, &mut self.f);
    }

    /// The phase the forcing term is read at: the integrator's, or with a final velocity
    /// [`Clock::closed_form_phase`].
    #[inline(always)]
    fn forcing_phase(&self) -> f64 {
        match self.final_velocity {
            None => self.x,
            Some(_) => self.clock.closed_form_phase(self.x, self.cfg.alpha_x),
        }
    }

    /// `tau dz/dt` of the current state with the coupling terms, and the position repulsion's
    /// stiffness into `self.stiffness`.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn derivative(&mut self, coupled: bool) -> [f64; N] {
        let mut h = match &self.final_velocity {
            None => self.spring(),
            Some(v) => self.moving_spring(v),
        };
        if let Some(lim) = &self.limits {
            for d in 0..3 {
                self.stiffness[d] = match lim.repulsion(d, self.p[d]) {
                    Some((c, slope)) => {
                        h[d] += c;
                        slope.min(-f64::MIN_POSITIVE)
                    }
                    None => 0.0,
                };
            }
        }
        if !self.obstacles.is_empty() {
            let zp = [self.z[0], self.z[1], self.z[2]];
            let bound = self.push_bound(&zp);
            let mut push = [0.0; 3];
            for o in &self.obstacles {
                o.add_repulsion(
                    &self.obstacle_gains,
                    &self.p,
                    &zp,
                    bound,
                    self.speed_up(),
                    &mut push,
                );
            }
            // Each sphere's push is bounded; their sum is too, however many there are.
            let size = (push[0] * push[0] + push[1] * push[1] + push[2] * push[2]).sqrt();
            if size > bound {
                push = push.map(|c| c * (bound / size));
            }
            for d in 0..3 {
                h[d] += push[d];
            }
        }
        if coupled {
            for (h, c) in h.iter_mut().zip(&self.user) {
                *h += c;
            }
        }
        h
    }

    /// `tau dz/dt` of the springs and the forcing term towards the (filtered) goal.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn spring(&mut self) -> [f64; N] {
        let cfg = &self.cfg;
        let mut h = [0.0; N];
        for d in 0..3 {
            h[d] =
                cfg.alpha_z * (cfg.beta_z * (self.goal_p[d] - self.p[d]) - self.z[d]) + self.f[d];
        }
        // Half the rotation vector from q to the goal.
        let e = quaternion::log(&quaternion::product(
            &self.goal_q,
            &quaternion::conjugate(&self.q),
        ));
        self.to_goal = e;
        for d in 0..3 {
            let to_goal = 2.0 * e[d];
            h[3 + d] = cfg.alpha_z * (cfg.beta_z * to_goal - self.z[3 + d]) + self.f[3 + d];
        }
        h
    }

    /// [`Self::spring`] towards the goals moving with the final velocity, `v` per unit of scaled
    /// time, as the rollout's (docs/cartesian.md, "A final velocity"): the scaled time to go from
    /// the phase at the current time scale and the clock's sub-step, the moving goals from the
    /// filtered goal pose.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn moving_spring(&self, v: &[f64; N]) -> [f64; N] {
        let cfg = &self.cfg;
        let hs = self.clock.dt / self.clock.substeps as f64;
        let to_go = phase_to_go(self.x, phase_clock(self.clock.tau, cfg.alpha_x, hs));
        let mut h = [0.0; N];
        for d in 0..3 {
            h[d] =
                moving_spring(cfg, self.goal_p[d], v[d], to_go, self.p[d], self.z[d]) + self.f[d];
        }
        let target = moving_goal(&self.goal_q, &[v[3], v[4], v[5]], -0.5 * to_go);
        let e = quaternion::log(&quaternion::product(
            &target,
            &quaternion::conjugate(&self.q),
        ));
        for d in 0..3 {
            let to_goal = 2.0 * e[d];
            let spring = cfg.alpha_z * (cfg.beta_z * to_goal + v[3 + d] - self.z[3 + d]);
            h[3 + d] = spring + self.f[3 + d];
        }
        h
    }

    /// The Cartesian rollout's `until_rest` criterion at the current state, towards the target
    /// goal, with the goal filter settled. Never with a final velocity: the movement goes on.
    #[inline(always)]
    fn rest(&self) -> bool {
        let cfg = &self.cfg;
        let tol = self.rest_tol;
        if self.goal_moving
            || self.final_velocity.is_some()
            || self.x * self.max_w / (cfg.alpha_z * cfg.beta_z) > tol
        {
            return false;
        }
        // The goal does not move, so it is the target, and the derivative just took the
        // logarithm to it.
        let e = self.to_goal;
        (0..3).all(|d| {
            (self.target_p[d] - self.p[d]).abs() <= tol
                && (2.0 * e[d]).abs() <= tol
                && self.z[d].abs() <= tol
                && self.z[3 + d].abs() <= tol
        })
    }

    /// Whether the current state, whose `tau dz/dt` is `self.h`, has stopped for good without a
    /// new goal, obstacles or coupling: the forcing term spent, the goal filter settled, every
    /// scaled velocity within `rest_tol` and every net pull too small to move the rest point by
    /// `rest_tol` (`|h| <= alpha_z beta_z rest_tol`; a turning point has a large one).
    #[inline(always)]
    fn stalled(&self) -> bool {
        let cfg = &self.cfg;
        let tol = self.rest_tol;
        let spring = cfg.alpha_z * cfg.beta_z;
        !self.goal_moving
            && self.final_velocity.is_none()
            && self.x * self.max_w / spring <= tol
            && self.z.iter().all(|z| z.abs() <= tol)
            && self.h.iter().all(|h| h.abs() <= spring * tol)
    }

    #[inline(always)]
    fn check_finite(&self) -> Result<()> {
        let state = [&self.p[..], &self.q, &self.z, &self.out_acceleration];
        check_state("Cartesian DMP stepper", self.x, &state, self.steps)
    }

    /// The phase `x` of the last command (1 before the first step).
    pub fn phase(&self) -> f64 {
        self.out_x
    }
    /// The time scale `tau_eff` of the last command's period (s).
    pub fn tau(&self) -> f64 {
        self.out_tau
    }
    pub fn nominal_tau(&self) -> f64 {
        self.clock.nominal
    }
    /// As [`crate::stepper::Stepper::done`], with the Cartesian rollout's criterion (position in
    /// its units, orientation in rad).
    pub fn done(&self) -> bool {
        self.at_rest
    }
    /// Whether the last command came to rest away from its goal: it stopped (every scaled
    /// velocity within `rest_tol`, the net pull `|tau dz/dt|` within `alpha_z beta_z rest_tol`,
    /// the forcing term spent, the goal filter settled) but is not
    /// [`CartesianStepper::done`]. Something holds it (an obstacle it cannot go round, a position
    /// limit, a coupling term): further steps repeat it until the goal, the obstacles or the
    /// coupling change. False before the first step and while moving.
    pub fn blocked(&self) -> bool {
        self.blocked
    }
    /// As [`crate::stepper::Stepper::over_limit`].
    pub fn over_limit(&self) -> bool {
        self.over_limit
    }
    pub fn steps(&self) -> u64 {
        self.steps
    }
    /// The goal pose the spring currently pulls towards (moving while filtered).
    pub fn goal(&self) -> [f64; POSE_WIDTH] {
        let (p, q) = (self.goal_p, self.goal_q);
        [p[0], p[1], p[2], q[0], q[1], q[2], q[3]]
    }
    pub fn goal_target(&self) -> [f64; POSE_WIDTH] {
        let (p, q) = (self.target_p, self.target_q);
        [p[0], p[1], p[2], q[0], q[1], q[2], q[3]]
    }
    pub fn dt(&self) -> f64 {
        self.clock.dt
    }
    pub fn substeps(&self) -> usize {
        self.clock.substeps
    }
    pub fn dmp(&self) -> &CartesianDmp {
        &self.dmp
    }
    pub fn obstacles(&self) -> &[SphereObstacle] {
        &self.obstacles
    }
    /// The last command, `(pose, [v, omega], [a, omegadot])`.
    pub fn output(&self) -> (&[f64; POSE_WIDTH], &[f64; N], &[f64; N]) {
        (&self.out_pose, &self.out_velocity, &self.out_acceleration)
    }
}
