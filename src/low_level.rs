//! The stages' own drivers, for those who test, benchmark or extend them: the steerable filter
//! bank (eqs 3–6), the multiscale Harris stage (eqs 7–8), the covariant merge, the descriptors
//! (eqs 9–10 and the steered one), the EKF and its motion model (eqs 13–27), the neural field
//! (eqs 28–45) and the GIST engines, with the generated test scenes and the seeded generator.
//!
//! A robot program needs none of this: the crate root has the detector, SLAM and the
//! controller. These paths follow the stages' internals and may change between releases.

/// The steerable filter bank: basis responses and steered images, CPU and GPU (eqs 3–6).
pub mod filter_bank {
    pub use crate::features::filter_bank::*;
}

/// The multiscale Harris stage: structure tensor, responses and suppression (eqs 7–8), its
/// tile plan, CPU and GPU.
pub mod harris {
    pub use crate::features::harris::*;
}

/// The covariant merge of the steered detections into keypoints.
pub mod merge {
    pub use crate::features::merge::*;
}

/// The steered descriptor: first-order steered responses in the keypoint's frame, CPU and GPU.
pub mod steered {
    pub use crate::features::steered::*;
}

/// The paper's colour-entropy descriptor (eqs 9–10).
pub mod descriptor {
    pub use crate::features::descriptor::*;
}

/// The inverse-depth EKF (eqs 13–27).
pub mod ekf {
    pub use crate::slam::ekf::*;
}

/// The camera's motion models: constant velocity and odometry-driven prediction.
pub mod motion {
    pub use crate::slam::motion::*;
}

/// The discretised dynamic neural field over headings (eqs 28–45), CPU and GPU.
pub mod dnf {
    pub use crate::nav::dnf::*;
}

/// The GPU context's selection: the `auto` policy and the `STEERNAV_REQUIRE_GPU` switch.
pub mod gpu {
    pub use crate::gpu::context::{auto_context, auto_refusal, gpu_required};
}

/// Procedural test scenes and rotations of an image.
pub mod synth {
    pub use crate::synth::*;
}

/// The seeded generator of every procedural choice, RANSAC and k-means++.
pub mod rng {
    pub use crate::rng::*;
}

/// Splitting one set of inputs between the machines of a job array.
pub mod shard {
    pub use crate::shard::*;
}

/// The GIST engines behind [`crate::nav::gist::Gist`]: the Gabor bank, the pooled grid and
/// k-means, on the CPU and on the GPU.
pub mod gist {
    /// The CPU engine.
    pub mod cpu {
        pub use crate::nav::gist::cpu::*;
    }
    /// The GPU engine.
    pub mod gpu {
        pub use crate::nav::gist::gpu::*;
    }
}
