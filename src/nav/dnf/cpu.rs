//! The dynamic neural field of eqs 28–31: a ring of N heading neurons,
//! τ u̇(φ) = −u(φ) + S(φ) + h + Σ_φ' w(φ, φ') f(u(φ')) (eq 30), integrated by Euler steps, with the
//! interaction kernel of eq 31 (+1 within 3 neighbours on the ring, −2.2 otherwise in the paper,
//! −1 by default here: see [`FieldConfig::interaction`]) or a
//! difference of Gaussians, f a Heaviside step or a sigmoid, and the chosen heading
//! φ_F = argmax u (eq 29). Headings wrap: neuron i stands for the angle 2πi/N.
//!
//! [`FieldBatch`] advances B independent fields at once (robots, episodes, parameter sets). The
//! piecewise-constant kernel of eq 31 needs only the total activity and a window sum over the
//! ring, so a step costs O(N·width) per field instead of the O(N²) of a matrix product.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The lateral interaction w(φ, φ') as a function of ring distance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case")]
pub enum Interaction {
    /// Eq 31: `excite` within `width` neighbours (ring distance ≤ width), `inhibit` beyond.
    Amari {
        /// Weight within the window (paper: 1).
        excite: f32,
        /// Weight outside it (paper: −2.2).
        inhibit: f32,
        /// Half-width in neurons (paper: 3).
        width: usize,
    },
    /// a_e·exp(−d²/2σ_e²) − a_i·exp(−d²/2σ_i²) − global, d the ring distance in neurons.
    GaussianDifference {
        /// Excitation amplitude.
        a_e: f32,
        /// Excitation width (neurons).
        sigma_e: f32,
        /// Inhibition amplitude.
        a_i: f32,
        /// Inhibition width (neurons).
        sigma_i: f32,
        /// Global inhibition.
        global: f32,
    },
}

/// The output non-linearity f.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case")]
pub enum Activation {
    /// f(u) = 1 if u > 0 else 0.
    Heaviside,
    /// f(u) = 1 / (1 + exp(−β u)).
    Sigmoid {
        /// Steepness β.
        beta: f32,
    },
}

impl Activation {
    /// f(u).
    #[inline]
    pub fn apply(self, u: f32) -> f32 {
        match self {
            Activation::Heaviside => (u > 0.0) as u32 as f32,
            Activation::Sigmoid { beta } => 1.0 / (1.0 + (-beta * u).exp()),
        }
    }
}

/// Parameters of the field (eq 30), with documented defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FieldConfig {
    /// Number of heading neurons N. Default 72 (5° each).
    pub neurons: usize,
    /// Time constant τ (s). Default 0.1.
    pub tau: f32,
    /// Euler step (s). Default 0.01.
    pub dt: f32,
    /// Resting level h. Default −2.
    pub h: f32,
    /// Lateral interaction. Default eq 31's shape, +1 within 3 neighbours, with **−1** beyond
    /// instead of the paper's −2.2. Against a stimulus whose range is a few units (the target's
    /// tent falls by 2 per radian), −2.2 per active neuron pins a formed peak where it is: the
    /// chosen heading trailed a free real motion by 9–20° on the CARMEN logs, and a robot
    /// passing its goal beside a pillar kept the old heading and drove away. At −1 the peak
    /// follows a swinging target (6–7°; every pillar placement reaches its goal) and still
    /// picks one winner between two stimuli 10% apart; below −0.9 it no longer does
    /// (docs/NAVIGATION.md).
    pub interaction: Interaction,
    /// Output non-linearity. Default Heaviside.
    pub activation: Activation,
}

impl Default for FieldConfig {
    fn default() -> Self {
        Self::refined(1)
    }
}

impl FieldConfig {
    /// The default field on a lattice `factor` times finer: 72·`factor` neurons of 5°/`factor`,
    /// eq 31's window the same ±15° (3·`factor` neighbours) and its weights divided by
    /// `factor`, so a peak of a given angular width excites and inhibits as much as on the
    /// default lattice (`factor` 1). On 5° neurons a formed peak moves only when the input
    /// difference between two neighbours beats the kernel's step, so a slowly drifting input
    /// leaves it pinned; a finer lattice lets it drift (docs/NAVIGATION.md, the replay).
    pub fn refined(factor: usize) -> Self {
        let f = factor.max(1);
        Self {
            neurons: 72 * f,
            tau: 0.1,
            dt: 0.01,
            h: -2.0,
            interaction: Interaction::Amari {
                excite: 1.0 / f as f32,
                inhibit: -1.0 / f as f32,
                width: 3 * f,
            },
            activation: Activation::Heaviside,
        }
    }

    /// Checks every value; the error names the field.
    pub fn validate(&self) -> Result<()> {
        let bad = |field: &'static str, value: String, reason: &str| {
            Err(Error::config(field, value, reason))
        };
        if !(3..=4096).contains(&self.neurons) {
            return bad("neurons", self.neurons.to_string(), "must be in 3..=4096");
        }
        if !(self.tau.is_finite() && self.tau > 0.0) {
            return bad("tau", self.tau.to_string(), "must be a finite number > 0");
        }
        if !(self.dt.is_finite() && self.dt > 0.0 && self.dt <= self.tau) {
            return bad(
                "dt",
                self.dt.to_string(),
                "must be finite, > 0 and ≤ tau (Euler stability)",
            );
        }
        if !self.h.is_finite() {
            return bad("h", self.h.to_string(), "must be finite");
        }
        let finite = match self.interaction {
            Interaction::Amari {
                excite,
                inhibit,
                width,
            } => {
                if 2 * width + 1 > self.neurons {
                    return bad(
                        "interaction.width",
                        width.to_string(),
                        "the window must fit on the ring",
                    );
                }
                excite.is_finite() && inhibit.is_finite()
            }
            Interaction::GaussianDifference {
                a_e,
                sigma_e,
                a_i,
                sigma_i,
                global,
            } => {
                [a_e, a_i, global].iter().all(|v| v.is_finite())
                    && sigma_e > 0.0
                    && sigma_i > 0.0
                    && sigma_e.is_finite()
                    && sigma_i.is_finite()
            }
        };
        if !finite {
            return bad(
                "interaction",
                format!("{:?}", self.interaction),
                "weights must be finite, widths > 0",
            );
        }
        if let Activation::Sigmoid { beta } = self.activation {
            if !(beta.is_finite() && beta > 0.0) {
                return bad(
                    "activation.beta",
                    beta.to_string(),
                    "must be a finite number > 0",
                );
            }
        }
        Ok(())
    }

    /// The kernel as a function of ring distance 0..=N/2 (dense form, used by the GPU and by
    /// the difference-of-Gaussians path).
    pub fn kernel_by_distance(&self) -> Vec<f32> {
        (0..=self.neurons / 2)
            .map(|d| match self.interaction {
                Interaction::Amari {
                    excite,
                    inhibit,
                    width,
                } => {
                    if d <= width {
                        excite
                    } else {
                        inhibit
                    }
                }
                Interaction::GaussianDifference {
                    a_e,
                    sigma_e,
                    a_i,
                    sigma_i,
                    global,
                } => {
                    let d2 = (d * d) as f32;
                    a_e * (-d2 / (2.0 * sigma_e * sigma_e)).exp()
                        - a_i * (-d2 / (2.0 * sigma_i * sigma_i)).exp()
                        - global
                }
            })
            .collect()
    }
}

/// Checks a stimulus of `fields × neurons` finite values; errors name the offending value.
pub fn check_stimulus(stimulus: &[f32], fields: usize, neurons: usize) -> Result<()> {
    if stimulus.len() != fields * neurons {
        return Err(Error::Config {
            field: "stimulus",
            value: format!("{} values", stimulus.len()),
            reason: format!("expected fields × neurons = {}", fields * neurons),
        });
    }
    if let Some(i) = stimulus.iter().position(|v| !v.is_finite()) {
        return Err(Error::Config {
            field: "stimulus",
            value: stimulus[i].to_string(),
            reason: format!(
                "value {i} (field {}, neuron {}) is not finite",
                i / neurons,
                i % neurons
            ),
        });
    }
    Ok(())
}

/// Heading (radians, [0, 2π)) of neuron `i` on a ring of `n`.
pub fn heading(i: usize, n: usize) -> f32 {
    i as f32 * std::f32::consts::TAU / n as f32
}

/// B independent fields of N neurons, stored field after field.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldBatch {
    /// The configuration (shared by all fields).
    pub config: FieldConfig,
    /// Activations, `fields × neurons`.
    pub u: Vec<f32>,
    /// Number of fields B.
    pub fields: usize,
}

impl FieldBatch {
    /// B fields at rest (u = h).
    pub fn new(config: FieldConfig, fields: usize) -> Result<Self> {
        config.validate()?;
        if fields == 0 {
            return Err(Error::Config {
                field: "fields",
                value: "0".into(),
                reason: "at least one field".into(),
            });
        }
        let u = vec![config.h; fields * config.neurons];
        Ok(Self { config, u, fields })
    }

    /// Advances every field by `steps` Euler steps under `stimulus` (`fields × neurons`, held
    /// constant over the steps). Non-finite stimulus values are refused.
    pub fn step(&mut self, stimulus: &[f32], steps: usize) -> Result<()> {
        check_stimulus(stimulus, self.fields, self.config.neurons)?;
        let n = self.config.neurons;
        let cfg = &self.config;
        if let (
            Interaction::Amari {
                excite,
                inhibit,
                width,
            },
            true,
        ) = (cfg.interaction, self.fields >= LANES)
        {
            // Blocks of LANES fields, neuron-major, so every operation runs across the fields
            // (fewer fields than a block are faster one by one, below).
            self.u
                .par_chunks_mut(LANES * n)
                .zip(stimulus.par_chunks(LANES * n))
                .for_each(|(u, s)| amari_block(cfg, excite, inhibit, width, u, s, steps));
            return Ok(());
        }
        let kernel = cfg.kernel_by_distance();
        self.u
            .par_chunks_mut(n)
            .zip(stimulus.par_chunks(n))
            .with_min_len(16)
            .for_each_init(
                || (vec![0.0f32; n], vec![0.0f32; n], Vec::with_capacity(2 * n)),
                |(f, lateral, ext), (u, s)| run_steps(cfg, &kernel, u, s, f, lateral, ext, steps),
            );
        Ok(())
    }

    /// φ_F of field `b` (eq 29): the heading of the most active neuron (lowest index on ties).
    pub fn peak(&self, b: usize) -> (usize, f32) {
        let n = self.config.neurons;
        let u = &self.u[b * n..(b + 1) * n];
        let i = (0..n).fold(0, |best, i| if u[i] > u[best] { i } else { best });
        (i, heading(i, n))
    }

    /// Field `b`'s activations.
    pub fn field(&self, b: usize) -> &[f32] {
        let n = self.config.neurons;
        &self.u[b * n..(b + 1) * n]
    }
}

/// Fields per block of the eq-31 path.
const LANES: usize = 8;

/// `steps` Euler steps of up to LANES fields under eq 31's kernel, transposed so that each
/// neuron's values for the block's fields sit in one vector: the activation, the total, the
/// sliding window (Heaviside outputs are 0/1, so its running sums are exact) and the update
/// all run across fields. Compiled for AVX2 + FMA where the processor has them.
fn amari_block(
    cfg: &FieldConfig,
    excite: f32,
    inhibit: f32,
    width: usize,
    u: &mut [f32],
    s: &[f32],
    steps: usize,
) {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::has_avx2_fma() {
        // SAFETY: the CPU supports AVX2 and FMA (checked above).
        return unsafe { amari_block_avx2(cfg, excite, inhibit, width, u, s, steps) };
    }
    amari_block_body(cfg, excite, inhibit, width, u, s, steps);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn amari_block_avx2(
    cfg: &FieldConfig,
    excite: f32,
    inhibit: f32,
    width: usize,
    u: &mut [f32],
    s: &[f32],
    steps: usize,
) {
    amari_block_body(cfg, excite, inhibit, width, u, s, steps);
}

#[inline(always)]
fn amari_block_body(
    cfg: &FieldConfig,
    excite: f32,
    inhibit: f32,
    width: usize,
    u: &mut [f32],
    s: &[f32],
    steps: usize,
) {
    type Lanes = [f32; LANES];
    let n = cfg.neurons;
    let fields = u.len() / n;
    let mut ut: Vec<Lanes> = vec![[0.0; LANES]; n];
    let mut st: Vec<Lanes> = vec![[0.0; LANES]; n];
    for b in 0..fields {
        for i in 0..n {
            ut[i][b] = u[b * n + i];
            st[i][b] = s[b * n + i];
        }
    }
    let mut f: Vec<Lanes> = vec![[0.0; LANES]; n];
    let rate = cfg.dt / cfg.tau;
    let gain = excite - inhibit;
    let add_index: Vec<usize> = (0..n).map(|i| (i + width + 1) % n).collect();
    let sub_index: Vec<usize> = (0..n).map(|i| (i + n - width) % n).collect();
    for _ in 0..steps {
        let mut total: Lanes = [0.0; LANES];
        match cfg.activation {
            Activation::Heaviside => {
                for (fi, ui) in f.iter_mut().zip(&ut) {
                    for l in 0..LANES {
                        fi[l] = if ui[l] > 0.0 { 1.0 } else { 0.0 };
                    }
                }
            }
            act => {
                for (fi, ui) in f.iter_mut().zip(&ut) {
                    for l in 0..LANES {
                        fi[l] = act.apply(ui[l]);
                    }
                }
            }
        }
        for fi in &f {
            for l in 0..LANES {
                total[l] += fi[l];
            }
        }
        // Window of neuron 0: neurons −width..=width around the ring.
        let mut window: Lanes = [0.0; LANES];
        for k in 0..=2 * width {
            let fk = &f[(k + n - width) % n];
            for l in 0..LANES {
                window[l] += fk[l];
            }
        }
        let base: Lanes = std::array::from_fn(|l| inhibit * total[l] + cfg.h);
        for i in 0..n {
            let (ui, si) = (&mut ut[i], &st[i]);
            for l in 0..LANES {
                ui[l] += rate * (-ui[l] + si[l] + base[l] + gain * window[l]);
            }
            let (add, sub) = (&f[add_index[i]], &f[sub_index[i]]);
            for l in 0..LANES {
                window[l] += add[l] - sub[l];
            }
        }
    }
    for b in 0..fields {
        for i in 0..n {
            u[b * n + i] = ut[i][b];
        }
    }
}

/// `steps` Euler steps of one field, compiled for AVX2 + FMA where the processor has them
/// (chosen once per field and call, not per step).
#[allow(clippy::too_many_arguments)]
fn run_steps(
    cfg: &FieldConfig,
    kernel: &[f32],
    u: &mut [f32],
    s: &[f32],
    f: &mut [f32],
    lateral: &mut [f32],
    ext: &mut Vec<f32>,
    steps: usize,
) {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::has_avx2_fma() {
        // SAFETY: the CPU supports AVX2 and FMA (checked above).
        return unsafe { run_steps_avx2(cfg, kernel, u, s, f, lateral, ext, steps) };
    }
    for _ in 0..steps {
        step_field(cfg, kernel, u, s, f, lateral, ext);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
unsafe fn run_steps_avx2(
    cfg: &FieldConfig,
    kernel: &[f32],
    u: &mut [f32],
    s: &[f32],
    f: &mut [f32],
    lateral: &mut [f32],
    ext: &mut Vec<f32>,
    steps: usize,
) {
    for _ in 0..steps {
        step_field(cfg, kernel, u, s, f, lateral, ext);
    }
}

/// One Euler step of one field (eq 30). `ext` is scratch for the ring padded by the window.
#[inline(always)]
fn step_field(
    cfg: &FieldConfig,
    kernel: &[f32],
    u: &mut [f32],
    s: &[f32],
    f: &mut [f32],
    lateral: &mut [f32],
    ext: &mut Vec<f32>,
) {
    let n = u.len();
    match cfg.activation {
        // Written as a select so the compiler vectorises it.
        Activation::Heaviside => {
            for (fi, &ui) in f.iter_mut().zip(u.iter()) {
                *fi = if ui > 0.0 { 1.0 } else { 0.0 };
            }
        }
        act => {
            for (fi, &ui) in f.iter_mut().zip(u.iter()) {
                *fi = act.apply(ui);
            }
        }
    }
    match cfg.interaction {
        Interaction::Amari {
            excite,
            inhibit,
            width,
        } => {
            // Σ w f = inhibit·Σ f + (excite − inhibit)·(sum over the window of ±width): the
            // window sums are 2·width+1 shifted adds over the ring padded on both sides, the
            // same order of additions as the shader's.
            let total: f32 = f.iter().sum();
            ext.clear();
            ext.extend_from_slice(&f[n - width..]);
            ext.extend_from_slice(f);
            ext.extend_from_slice(&f[..width]);
            lateral.fill(0.0);
            for k in 0..=2 * width {
                for (l, &e) in lateral.iter_mut().zip(&ext[k..k + n]) {
                    *l += e;
                }
            }
            let gain = excite - inhibit;
            let base = inhibit * total;
            for l in lateral.iter_mut() {
                *l = base + gain * *l;
            }
        }
        Interaction::GaussianDifference { .. } => {
            for (i, l) in lateral.iter_mut().enumerate() {
                *l = (0..n).map(|j| kernel[ring_distance(i, j, n)] * f[j]).sum();
            }
        }
    }
    let rate = cfg.dt / cfg.tau;
    let h = cfg.h;
    for ((ui, &si), &li) in u.iter_mut().zip(s).zip(lateral.iter()) {
        *ui += rate * (-*ui + si + h + li);
    }
}

/// Distance between neurons i and j on a ring of n.
pub fn ring_distance(i: usize, j: usize, n: usize) -> usize {
    let d = i.abs_diff(j);
    d.min(n - d)
}

/// A bell-shaped stimulus on the ring: `amplitude`·exp(−d²/2σ²) around neuron `centre`.
pub fn bell(n: usize, centre: f32, amplitude: f32, sigma: f32) -> Vec<f32> {
    (0..n)
        .map(|i| {
            let d = (i as f32 - centre).rem_euclid(n as f32);
            let d = d.min(n as f32 - d);
            amplitude * (-d * d / (2.0 * sigma * sigma)).exp()
        })
        .collect()
}
