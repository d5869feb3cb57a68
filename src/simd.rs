//! The two inner loops the CPU backend spends its time in, compiled twice: for the baseline
//! target and, on x86-64 machines that have them, for AVX2 + FMA, chosen at run time (the
//! check is a cached atomic load). The FMA version rounds once per multiply-add, so its
//! results differ from the baseline's in the last bits; parity tests allow for that.

/// `out[i] += k · (a[i] + sign · b[i])`.
#[inline]
pub fn fold_into(out: &mut [f32], a: &[f32], b: &[f32], k: f32, sign: f32) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU supports AVX2 and FMA (checked above).
        return unsafe { fold_into_avx2(out, a, b, k, sign) };
    }
    fold_into_plain(out, a, b, k, sign);
}

/// `acc[i] += w · src[i]`.
#[inline]
pub fn axpy(acc: &mut [f32], src: &[f32], w: f32) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU supports AVX2 and FMA (checked above).
        return unsafe { axpy_avx2(acc, src, w) };
    }
    axpy_plain(acc, src, w);
}

#[inline(always)]
fn fold_into_plain(out: &mut [f32], a: &[f32], b: &[f32], k: f32, sign: f32) {
    for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
        *o += k * (x + sign * y);
    }
}

#[inline(always)]
fn axpy_plain(acc: &mut [f32], src: &[f32], w: f32) {
    for (a, &s) in acc.iter_mut().zip(src) {
        *a += w * s;
    }
}

/// Whether the processor has AVX2 and FMA (cached by std after the first call).
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx2_fma() -> bool {
    std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn fold_into_avx2(out: &mut [f32], a: &[f32], b: &[f32], k: f32, sign: f32) {
    for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
        *o = k.mul_add(sign.mul_add(y, x), *o);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn axpy_avx2(acc: &mut [f32], src: &[f32], w: f32) {
    for (a, &s) in acc.iter_mut().zip(src) {
        *a = w.mul_add(s, *a);
    }
}

/// The largest value of `values`, or `floor` when none exceeds it. Eight independent lanes
/// with a compare-and-select each: the form the compiler turns into vector max instructions
/// (a running `f32::max` is a serial chain it cannot vectorise, and cost the Harris response
/// pass 85% at 1920×1080).
#[inline]
pub fn max_or(values: &[f32], floor: f32) -> f32 {
    let mut lanes = [floor; 8];
    let mut chunks = values.chunks_exact(8);
    for chunk in &mut chunks {
        for (lane, &v) in lanes.iter_mut().zip(chunk) {
            *lane = if v > *lane { v } else { *lane };
        }
    }
    let tail = chunks
        .remainder()
        .iter()
        .fold(floor, |m, &v| if v > m { v } else { m });
    lanes
        .into_iter()
        .fold(tail, |m, v| if v > m { v } else { m })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatched_loops_match_the_plain_ones() {
        let a: Vec<f32> = (0..37).map(|i| i as f32 * 0.5).collect();
        let b: Vec<f32> = (0..37).map(|i| 3.0 - i as f32).collect();
        let (mut x, mut y) = (vec![1.0f32; 37], vec![1.0f32; 37]);
        fold_into(&mut x, &a, &b, 0.25, -1.0);
        fold_into_plain(&mut y, &a, &b, 0.25, -1.0);
        assert_eq!(x, y);
        axpy(&mut x, &a, 2.0);
        axpy_plain(&mut y, &a, 2.0);
        assert_eq!(x, y);
    }
}
