//! Splitting one set of inputs between the N machines of a job array (Slurm `--array`,
//! Kubernetes indexed jobs): shard K of N takes the inputs whose relative path hashes to K, so
//! the shards cover the set with no overlap and no gap, whatever order each machine lists its
//! files in, and a re-run of one shard takes the same inputs.

use std::path::{Component, Path};
use std::str::FromStr;

use crate::error::Error;

/// Shard `index` of `count`, `0 ≤ index < count`; written `K/N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// K, from 0 (as `SLURM_ARRAY_TASK_ID` with `--array=0-(N-1)`, or
    /// `JOB_COMPLETION_INDEX` gives it).
    pub index: u64,
    /// N, at least 1.
    pub count: u64,
}

impl Shard {
    /// Shard `index` of `count`, checked.
    pub fn new(index: u64, count: u64) -> Result<Self, Error> {
        if count == 0 || index >= count {
            return Err(Error::Config {
                field: "shard",
                value: format!("{index}/{count}"),
                reason: "K/N needs N ≥ 1 and 0 ≤ K < N".into(),
            });
        }
        Ok(Self { index, count })
    }

    /// The shard a path relative to the set's root falls in: FNV-1a (64-bit) over its
    /// components joined by `/`, so `a/b.png` hashes alike on every platform and machine.
    pub fn of(relative: &Path, count: u64) -> u64 {
        let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
        let mut feed = |bytes: &[u8]| {
            for &b in bytes {
                hash ^= u64::from(b);
                hash = hash.wrapping_mul(0x0100_0000_01b3);
            }
        };
        let mut first = true;
        for component in relative.components() {
            let Component::Normal(part) = component else {
                continue;
            };
            if !first {
                feed(b"/");
            }
            first = false;
            feed(part.as_encoded_bytes());
        }
        hash % count.max(1)
    }

    /// Whether this shard takes the input at `relative` (a path under the set's root).
    pub fn contains(&self, relative: &Path) -> bool {
        Self::of(relative, self.count) == self.index
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = Error;

    fn from_str(text: &str) -> Result<Self, Error> {
        let bad = || Error::Config {
            field: "shard",
            value: format!("{text:?}"),
            reason: "expected K/N, two whole numbers with 0 ≤ K < N (0/4 … 3/4)".into(),
        };
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let k: u64 = k.trim().parse().map_err(|_| bad())?;
        let n: u64 = n.trim().parse().map_err(|_| bad())?;
        Self::new(k, n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_cover_a_set_once_and_hash_alike_everywhere() {
        let paths: Vec<String> = (0..500).map(|i| format!("d{}/img{i}.png", i % 7)).collect();
        for n in [1, 2, 3, 8] {
            let mut sizes = vec![0usize; n as usize];
            for p in &paths {
                let owners: Vec<u64> = (0..n)
                    .filter(|&k| Shard::new(k, n).unwrap().contains(Path::new(p)))
                    .collect();
                assert_eq!(owners.len(), 1, "{p} in shards {owners:?} of {n}");
                sizes[owners[0] as usize] += 1;
            }
            // Balanced within a few standard deviations of a fair split.
            let fair = paths.len() as f64 / n as f64;
            for s in sizes {
                assert!(
                    (s as f64 - fair).abs() < 4.0 * fair.sqrt() + 1.0,
                    "{s} vs {fair}"
                );
            }
        }
        // Separators and a leading ./ do not change the shard; the name does.
        assert_eq!(
            Shard::of(Path::new("./a/b.png"), 1 << 40),
            Shard::of(Path::new("a/b.png"), 1 << 40)
        );
        assert_ne!(
            Shard::of(Path::new("a/b.png"), 1 << 40),
            Shard::of(Path::new("ab.png"), 1 << 40)
        );
        // A fixed value (FNV-1a 64 of "a/b.png", computed independently): the split must
        // never change between releases, or a re-run shard would redo other shards' work.
        assert_eq!(
            Shard::of(Path::new("a/b.png"), u64::MAX),
            0xd065_2b38_3b1f_86f4
        );
    }

    #[test]
    fn bad_shards_are_refused_naming_the_rule() {
        for text in ["3/3", "1/0", "a/2", "2", "-1/2", "1/2/3"] {
            let e = text.parse::<Shard>().unwrap_err().to_string();
            assert!(e.contains("shard") && e.contains('K'), "{text}: {e}");
        }
        assert_eq!("1/4".parse::<Shard>().unwrap(), Shard::new(1, 4).unwrap());
        assert_eq!(Shard::new(2, 5).unwrap().to_string(), "2/5");
    }
}
