//! A navigation control loop fed by laser scans: each cycle the controller gets the scan, the
//! pose and the goal, and returns (v, ω). The scans here come from a small synthetic room (a
//! pillar between the robot and its goal), cast analytically; on a robot they come from the
//! scanner driver in the same form (`angle_min`, `angle_increment`, ranges):
//! `cargo run --release --example nav_controller`.
use steernav::nav::Mode;
use steernav::{Controller, ControllerConfig, LaserScan};

/// Range from `origin` along `angle` to a circle (centre, radius), or `max` when it misses.
fn ray_to_circle(origin: [f32; 2], angle: f32, centre: [f32; 2], radius: f32, max: f32) -> f32 {
    let (dx, dy) = (angle.cos(), angle.sin());
    let (ox, oy) = (origin[0] - centre[0], origin[1] - centre[1]);
    let b = ox * dx + oy * dy;
    let c = ox * ox + oy * oy - radius * radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return max;
    }
    let t = -b - disc.sqrt();
    if t > 0.0 {
        t.min(max)
    } else {
        max
    }
}

fn main() -> Result<(), steernav::Error> {
    // The robot's own control period, seconds.
    let period = 0.1f32;
    let config = ControllerConfig::default();
    let mut controller = Controller::new(config, Mode::Laser, Default::default())?;
    let (pillar, radius, goal) = ([4.0f32, -1.0], 0.5f32, [8.0f32, 0.0]);
    let (beams, range_max) = (181usize, 4.0f32);
    let angle_min = -std::f32::consts::FRAC_PI_2;
    let increment = std::f32::consts::PI / (beams - 1) as f32;
    let mut pose = [0.0f32, 0.0, 0.0];
    let mut closest = f32::INFINITY;
    for cycle in 0..600 {
        let ranges = (0..beams)
            .map(|i| {
                let bearing = angle_min + i as f32 * increment;
                ray_to_circle(
                    [pose[0], pose[1]],
                    pose[2] + bearing,
                    pillar,
                    radius,
                    range_max,
                )
            })
            .collect();
        let scan = LaserScan::new(ranges, angle_min, increment, range_max);
        let command = controller.step(&scan, pose, goal, None)?;
        // The robot's own motion: a unicycle over one control period.
        pose[0] += command.v * pose[2].cos() * period;
        pose[1] += command.v * pose[2].sin() * period;
        pose[2] += command.omega * period;
        closest = closest.min((pose[0] - pillar[0]).hypot(pose[1] - pillar[1]) - radius);
        if cycle % 10 == 0 {
            println!(
                "t {:4.1} s  pose ({:5.2}, {:5.2}, {:5.2})  v {:4.2}  ω {:5.2}",
                cycle as f32 * period,
                pose[0],
                pose[1],
                pose[2],
                command.v,
                command.omega
            );
        }
        if (goal[0] - pose[0]).hypot(goal[1] - pose[1]) < 0.3 {
            println!(
                "goal reached after {:.1} s; closest approach to the pillar {closest:.2} m",
                cycle as f32 * period
            );
            return Ok(());
        }
    }
    Err(steernav::Error::config(
        "example",
        "nav_controller",
        "the goal was not reached in 60 s",
    ))
}
