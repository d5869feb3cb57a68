//! The two inner loops the CPU backend spends its time in (the folded taps of every separable
//! convolution, and the structure tensor's weighted sums with the Harris response), compiled
//! twice: for the baseline target and, on x86-64 machines that have them, for AVX2 + FMA,
//! chosen at run time (the check is a cached atomic load). Both keep a block of 32 outputs in
//! registers across all their terms: one pass per term, reading and writing the outputs each
//! time, cost the Harris stage 23% more. The FMA version rounds once per multiply-add, so its
//! results differ from the baseline's in the last bits; parity tests allow for that.

/// `out[i] += k · (a[i] + sign · b[i])`, one pass per term: the reference [`fold_terms`] and
/// [`tensor_responses`] are tested against.
#[cfg(test)]
fn fold_into(out: &mut [f32], a: &[f32], b: &[f32], k: f32, sign: f32) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU supports AVX2 and FMA (checked above).
        return unsafe { fold_into_avx2(out, a, b, k, sign) };
    }
    fold_into_plain(out, a, b, k, sign);
}

/// One term of [`fold_terms`]: `k · (a + sign · b)` over two rows.
pub type FoldTerm<'a> = (&'a [f32], &'a [f32], f32, f32);

/// `out[i] = Σ_t k_t · (a_t[i] + sign_t · b_t[i])` over the `count` terms `term(t)`, summed
/// in order from 0: what zeroing `out` and one accumulation pass per term give, bit for bit, but
/// with each block of outputs kept in registers across the terms instead of read and written
/// back once per term.
#[inline]
pub fn fold_terms<'a>(out: &mut [f32], count: usize, term: impl Fn(usize) -> FoldTerm<'a> + Copy) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU supports AVX2 and FMA (checked above).
        return unsafe { fold_terms_avx2(out, count, term) };
    }
    fold_terms_with(out, count, term, |k, x, y, sign, o| o + k * (x + sign * y));
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn fold_terms_avx2<'a>(
    out: &mut [f32],
    count: usize,
    term: impl Fn(usize) -> FoldTerm<'a> + Copy,
) {
    fold_terms_with(
        out,
        count,
        term,
        |k: f32, x: f32, y: f32, sign: f32, o: f32| k.mul_add(sign.mul_add(y, x), o),
    );
}

/// Most terms [`fold_terms`] gathers before its blocked pass (a kernel of radius 63); more
/// are summed in several passes of this many.
const MAX_TERMS: usize = 64;

#[inline(always)]
fn fold_terms_with<'a>(
    out: &mut [f32],
    count: usize,
    term: impl Fn(usize) -> FoldTerm<'a> + Copy,
    fold: impl Fn(f32, f32, f32, f32, f32) -> f32 + Copy,
) {
    let n = out.len();
    // The terms' rows checked once, so the blocked loop reads them without bounds checks.
    let mut gathered = [(
        std::ptr::null::<f32>(),
        std::ptr::null::<f32>(),
        0.0f32,
        0.0f32,
    ); MAX_TERMS];
    // One pass when the terms fit (always, for the kernels the detector builds).
    for start in (0..count.max(1)).step_by(MAX_TERMS) {
        let batch = (count - start.min(count)).min(MAX_TERMS);
        for (slot, t) in gathered.iter_mut().zip(start..start + batch) {
            let (a, b, k, sign) = term(t);
            assert!(a.len() >= n && b.len() >= n);
            *slot = (a.as_ptr(), b.as_ptr(), k, sign);
        }
        let terms = &gathered[..batch];
        let mut i = 0;
        while i + LANES <= n {
            let mut acc = [0.0f32; LANES];
            if start > 0 {
                acc.copy_from_slice(&out[i..i + LANES]);
            }
            for &(a, b, k, sign) in terms {
                // SAFETY: both rows hold at least n ≥ i + LANES values (asserted above).
                let (a, b) = unsafe {
                    (
                        &*(a.add(i) as *const [f32; LANES]),
                        &*(b.add(i) as *const [f32; LANES]),
                    )
                };
                for ((o, &x), &y) in acc.iter_mut().zip(a).zip(b) {
                    *o = fold(k, x, y, sign, *o);
                }
            }
            out[i..i + LANES].copy_from_slice(&acc);
            i += LANES;
        }
        if i < n {
            if start == 0 {
                out[i..].fill(0.0);
            }
            for &(a, b, k, sign) in terms {
                for (j, o) in out.iter_mut().enumerate().skip(i) {
                    // SAFETY: j < n, and both rows hold at least n values.
                    let (x, y) = unsafe { (*a.add(j), *b.add(j)) };
                    *o = fold(k, x, y, sign, *o);
                }
            }
        }
    }
}

/// The structure tensor's three entries as weighted sums of the blurred products (product
/// p's row is `q[p · out.len()..][..out.len()]`, `terms[e]` the (product, weight) pairs of
/// entry e, summed in list order from 0) and `out[i] = harris(M_xx, M_xy, M_yy)`, in one pass over the row that keeps the
/// three sums in registers. Each sum takes its terms in order with one multiply-add each (a
/// fused one where [`fold_terms`] fuses), the arithmetic of one accumulation pass per term.
#[inline]
pub fn tensor_responses(
    q: &[f32],
    terms: &[Vec<(usize, f32)>; 3],
    out: &mut [f32],
    harris: impl Fn(f32, f32, f32) -> f32 + Copy,
) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU supports AVX2 and FMA (checked above).
        return unsafe { tensor_responses_avx2(q, terms, out, harris) };
    }
    tensor_responses_with(q, terms, out, harris, |w, s, a| a + w * s);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn tensor_responses_avx2(
    q: &[f32],
    terms: &[Vec<(usize, f32)>; 3],
    out: &mut [f32],
    harris: impl Fn(f32, f32, f32) -> f32 + Copy,
) {
    tensor_responses_with(q, terms, out, harris, |w: f32, s: f32, a: f32| {
        w.mul_add(s, a)
    });
}

/// Lanes of [`tensor_responses`]: four 8-wide vectors per sum, so each term's weight, bounds
/// check and address cost a quarter of what they would for one.
const LANES: usize = 32;

#[inline(always)]
fn tensor_responses_with(
    q: &[f32],
    terms: &[Vec<(usize, f32)>; 3],
    out: &mut [f32],
    harris: impl Fn(f32, f32, f32) -> f32 + Copy,
    madd: impl Fn(f32, f32, f32) -> f32 + Copy,
) {
    let n = out.len();
    let mut i = 0;
    while i + LANES <= n {
        let mut m = [[0.0f32; LANES]; 3];
        for (acc, list) in m.iter_mut().zip(terms) {
            for &(p, w) in list {
                let src: &[f32; LANES] = q[p * n + i..p * n + i + LANES].try_into().unwrap();
                for (a, &s) in acc.iter_mut().zip(src) {
                    *a = madd(w, s, *a);
                }
            }
        }
        for (l, o) in out[i..i + LANES].iter_mut().enumerate() {
            *o = harris(m[0][l], m[1][l], m[2][l]);
        }
        i += LANES;
    }
    for (j, o) in out.iter_mut().enumerate().skip(i) {
        let mut m = [0.0f32; 3];
        for (acc, list) in m.iter_mut().zip(terms) {
            for &(p, w) in list {
                *acc = madd(w, q[p * n + j], *acc);
            }
        }
        *o = harris(m[0], m[1], m[2]);
    }
}

#[cfg(test)]
fn fold_into_plain(out: &mut [f32], a: &[f32], b: &[f32], k: f32, sign: f32) {
    for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
        *o += k * (x + sign * y);
    }
}

/// Whether the processor has AVX2 and FMA (cached by std after the first call).
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx2_fma() -> bool {
    std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
}

#[cfg(all(test, target_arch = "x86_64"))]
#[target_feature(enable = "avx2,fma")]
unsafe fn fold_into_avx2(out: &mut [f32], a: &[f32], b: &[f32], k: f32, sign: f32) {
    for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
        *o = k.mul_add(sign.mul_add(y, x), *o);
    }
}

/// Bit x % 64 of `mask[x / 64]`, for x in `columns`: whether `mid[x]` exceeds `threshold` and
/// its 8 neighbours in the rows `[up, mid, down]` (the 3×3 test of the suppression). Bits
/// outside `columns` are cleared in the words the range touches. Each word's 64 tests run in a
/// branch-free pass (8 lanes wide with AVX2) and are packed into bits, so the caller visits the
/// few maxima by their set bits instead of testing every sample again. Comparisons round
/// nothing, so both builds agree exactly.
#[inline]
pub fn strict_maxima(
    rows: [&[f32]; 3],
    threshold: f32,
    columns: std::ops::Range<usize>,
    mask: &mut [u64],
) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU supports AVX2 (checked above).
        return unsafe { strict_maxima_avx2(rows, threshold, columns, mask) };
    }
    strict_maxima_with(rows, threshold, columns, mask);
}

/// The AVX2 build: eight columns per compare, their signs gathered by `movemask`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn strict_maxima_avx2(
    rows: [&[f32]; 3],
    threshold: f32,
    columns: std::ops::Range<usize>,
    mask: &mut [u64],
) {
    use std::arch::x86_64::{
        _mm256_and_ps, _mm256_cmp_ps, _mm256_loadu_ps, _mm256_movemask_ps, _mm256_set1_ps,
        _CMP_GT_OQ,
    };
    if columns.is_empty() {
        return;
    }
    let len = rows.iter().map(|r| r.len()).min().unwrap_or(0);
    assert!(columns.start >= 1 && columns.end < len);
    let t = _mm256_set1_ps(threshold);
    let words = columns.start / 64..columns.end.div_ceil(64);
    for (word, w) in mask[words.clone()].iter_mut().zip(words) {
        let base = w * 64;
        let mut bits = 0u64;
        for k in 0..8 {
            let x = base + 8 * k;
            if x + 8 <= columns.start || x >= columns.end {
                continue;
            }
            if x == 0 || x + 9 > len {
                // The rows' ends: column by column (bits outside `columns` are cleared below).
                let group = x.max(columns.start)..(x + 8).min(columns.end);
                bits |= strict_word(rows, threshold, &group, base);
                continue;
            }
            // SAFETY: columns [x − 1, x + 9) lie in every row (checked above).
            let v = _mm256_loadu_ps(rows[1].as_ptr().add(x));
            let mut keep = _mm256_cmp_ps::<_CMP_GT_OQ>(v, t);
            for (r, row) in rows.iter().enumerate() {
                for dx in 0..3 {
                    if r == 1 && dx == 1 {
                        continue;
                    }
                    let n = _mm256_loadu_ps(row.as_ptr().add(x + dx - 1));
                    keep = _mm256_and_ps(keep, _mm256_cmp_ps::<_CMP_GT_OQ>(v, n));
                }
            }
            bits |= (_mm256_movemask_ps(keep) as u32 as u64) << (8 * k);
        }
        // Only the columns of the range: groups at its ends test a few columns beyond it.
        let lo = columns.start.saturating_sub(base);
        let hi = (columns.end - base).min(64);
        let range = (u64::MAX >> (64 - (hi - lo))) << lo;
        *word = bits & range;
    }
}

/// The portable build: each word's 64 tests in a pass the compiler vectorises, packed into bits.
fn strict_maxima_with(
    [up, mid, down]: [&[f32]; 3],
    threshold: f32,
    columns: std::ops::Range<usize>,
    mask: &mut [u64],
) {
    if columns.is_empty() {
        return;
    }
    let words = columns.start / 64..columns.end.div_ceil(64);
    for (word, w) in mask[words.clone()].iter_mut().zip(words) {
        let base = w * 64;
        if !(columns.start <= base && base + 64 <= columns.end) {
            *word = strict_word([up, mid, down], threshold, &columns, base);
            continue;
        }
        // A whole word inside the range (so base ≥ 1): fixed-size windows, which the
        // compiler vectorises without bounds checks.
        let window =
            |r: &[f32]| -> [f32; 66] { r[base - 1..base + 65].try_into().expect("66 columns") };
        let (u, m, d) = (window(up), window(mid), window(down));
        let mut flags = [0u8; 64];
        for (i, flag) in flags.iter_mut().enumerate() {
            *flag = strict_at([&u, &m, &d], i + 1, threshold);
        }
        *word = pack_flags(&flags);
    }
}

/// The bits (bit x − `base` for column x) of the columns of `columns`, tested one at a time (at
/// the ends of a range or of the rows).
#[inline(always)]
fn strict_word(
    rows: [&[f32]; 3],
    threshold: f32,
    columns: &std::ops::Range<usize>,
    base: usize,
) -> u64 {
    (base.max(columns.start)..(base + 64).min(columns.end))
        .filter(|&x| strict_at(rows, x, threshold) == 1)
        .fold(0, |bits, x| bits | 1 << (x - base))
}

/// 1 when `mid[c]` exceeds `threshold` and its 8 neighbours in `[up, mid, down]`, else 0.
#[inline(always)]
fn strict_at([u, m, d]: [&[f32]; 3], c: usize, threshold: f32) -> u8 {
    let v = m[c];
    ((v > threshold)
        & (v > m[c - 1])
        & (v > m[c + 1])
        & (v > u[c - 1])
        & (v > u[c])
        & (v > u[c + 1])
        & (v > d[c - 1])
        & (v > d[c])
        & (v > d[c + 1])) as u8
}

/// 64 bytes of 0 or 1 as the bits of a word (byte i → bit i): eight bytes at a time, the
/// multiply gathering each byte's low bit into the top byte (no carry reaches it).
#[inline(always)]
fn pack_flags(flags: &[u8; 64]) -> u64 {
    let mut bits = 0u64;
    for (k, chunk) in flags.chunks_exact(8).enumerate() {
        let bytes = u64::from_le_bytes(chunk.try_into().expect("eight bytes"));
        bits |= (bytes.wrapping_mul(0x0102_0408_1020_4080) >> 56) << (8 * k);
    }
    bits
}

/// The indices of the set bits of `mask` (bit x % 64 of word x / 64), in increasing order.
#[inline]
pub fn set_bits(mask: &[u64]) -> impl Iterator<Item = usize> + '_ {
    mask.iter().enumerate().flat_map(|(w, &word)| {
        let mut bits = word;
        std::iter::from_fn(move || {
            (bits != 0).then(|| {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                w * 64 + i
            })
        })
    })
}

/// `out[i] = a[i] · b[i]` over the shortest of the three (8 lanes wide with AVX2; a product
/// rounds the same in every build).
#[inline]
pub fn multiply(out: &mut [f32], a: &[f32], b: &[f32]) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU supports AVX2 (checked above).
        return unsafe { multiply_avx2(out, a, b) };
    }
    multiply_lanes(out, a, b)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn multiply_avx2(out: &mut [f32], a: &[f32], b: &[f32]) {
    multiply_lanes(out, a, b)
}

#[inline(always)]
fn multiply_lanes(out: &mut [f32], a: &[f32], b: &[f32]) {
    for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
        *o = x * y;
    }
}

/// The largest value of `values`, or `floor` when none exceeds it. Eight independent lanes
/// with a compare-and-select each: the form the compiler turns into vector max instructions
/// (a running `f32::max` is a serial chain it cannot vectorise, and cost the Harris response
/// pass 85% at 1920×1080).
#[inline]
pub fn max_or(values: &[f32], floor: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: the CPU supports AVX2 (checked above).
        return unsafe { max_or_avx2(values, floor) };
    }
    max_or_lanes(values, floor)
}

/// [`max_or`] compiled for AVX2: eight lanes in one register instead of two.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn max_or_avx2(values: &[f32], floor: f32) -> f32 {
    max_or_lanes(values, floor)
}

#[inline(always)]
fn max_or_lanes(values: &[f32], floor: f32) -> f32 {
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
    fn strict_maxima_bits_are_the_plain_three_by_three_test() {
        // Integers so that ties (which are not strict maxima) are frequent.
        let mut state = 12345u32;
        let mut next = || {
            state = state.wrapping_mul(1_103_515_245).wrapping_add(12345);
            ((state >> 16) % 7) as f32
        };
        let width = 203usize;
        let rows: Vec<Vec<f32>> = (0..3)
            .map(|_| (0..width).map(|_| next()).collect())
            .collect();
        let [up, mid, down] = [&rows[0][..], &rows[1][..], &rows[2][..]];
        for columns in [
            1..width - 1,
            5..70,
            64..128,
            63..65,
            1..2,
            3..200,
            9..17,
            190..202,
        ] {
            let mut mask = vec![u64::MAX; width.div_ceil(64)];
            strict_maxima([up, mid, down], 2.0, columns.clone(), &mut mask);
            let mut plain = vec![0u64; mask.len()];
            strict_maxima_with([up, mid, down], 2.0, columns.clone(), &mut plain);
            let expected: Vec<usize> = columns
                .clone()
                .filter(|&x| {
                    let v = mid[x];
                    v > 2.0
                        && [up, mid, down]
                            .iter()
                            .flat_map(|r| &r[x - 1..=x + 1])
                            .filter(|&&n| n >= v)
                            .count()
                            == 1
                })
                .collect();
            let words = columns.start / 64..columns.end.div_ceil(64);
            let found: Vec<usize> = set_bits(&mask[words.clone()])
                .map(|x| x + words.start * 64)
                .collect();
            assert_eq!(found, expected, "columns {columns:?}");
            assert_eq!(
                mask[words.clone()],
                plain[words],
                "dispatched against plain"
            );
        }
        let mut untouched = vec![u64::MAX; 4];
        strict_maxima([up, mid, down], 2.0, 100..100, &mut untouched);
        assert_eq!(untouched, [u64::MAX; 4], "an empty range writes no word");
    }

    #[test]
    fn dispatched_loops_match_the_plain_ones() {
        let a: Vec<f32> = (0..37).map(|i| i as f32 * 0.5).collect();
        let b: Vec<f32> = (0..37).map(|i| 3.0 - i as f32).collect();
        let (mut x, mut y) = (vec![1.0f32; 37], vec![1.0f32; 37]);
        fold_into(&mut x, &a, &b, 0.25, -1.0);
        fold_into_plain(&mut y, &a, &b, 0.25, -1.0);
        assert_eq!(x, y);
        // Terms folded in registers give what one pass per term gives, tail included.
        let b2: Vec<f32> = b.iter().map(|v| v * 0.3 + 1.0).collect();
        let terms = [
            (&a[..], &b[..], 0.25f32, -1.0f32),
            (&b2[..], &a[..], -0.5, 1.0),
        ];
        let mut folded = vec![7.0f32; 37];
        fold_terms(&mut folded, terms.len(), |t| terms[t]);
        let mut passes = vec![0.0f32; 37];
        for (a, b, k, sign) in terms {
            fold_into(&mut passes, a, b, k, sign);
        }
        assert_eq!(folded, passes);
        // More terms than one pass gathers, and none.
        let many: Vec<FoldTerm> = (0..MAX_TERMS + 6)
            .map(|t| {
                (
                    &a[..],
                    &b2[..],
                    t as f32 * 0.01 - 0.3,
                    if t % 2 == 0 { 1.0 } else { -1.0 },
                )
            })
            .collect();
        fold_terms(&mut folded, many.len(), |t| many[t]);
        passes.fill(0.0);
        for &(a, b, k, sign) in &many {
            fold_into(&mut passes, a, b, k, sign);
        }
        assert_eq!(folded, passes);
        fold_terms(&mut folded, 0, |t| many[t]);
        assert!(folded.iter().all(|&v| v == 0.0));
        // The tensor's sums and response: every lane and the tail.
        let q: Vec<f32> = (0..3 * 37).map(|i| (i as f32 * 0.37).sin()).collect();
        let entries = [
            vec![(0, 0.5), (2, -1.5)],
            vec![(1, 2.0)],
            vec![(2, 0.25), (0, 1.0)],
        ];
        let mut r = vec![0.0f32; 37];
        tensor_responses(&q, &entries, &mut r, |xx, xy, yy| xx * yy - xy * xy);
        for (i, &v) in r.iter().enumerate() {
            let mut m = [0.0f32; 3];
            for (acc, list) in m.iter_mut().zip(&entries) {
                for &(p, w) in list {
                    let mut one = [*acc];
                    fold_into(&mut one, &[q[p * 37 + i]], &[0.0], w, 0.0);
                    *acc = one[0];
                }
            }
            assert_eq!(v, m[0] * m[2] - m[1] * m[1], "{i}");
        }
    }
}
