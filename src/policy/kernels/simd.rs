//! The fused kernels' loops compiled for the vector unit the CPU has, chosen at run time
//! (issue #16): the release build targets baseline x86-64 (SSE2) so that one binary runs
//! everywhere, which leaves AVX-512 and AVX2 idle in the element-wise loops.
//!
//! [`multiversion!`](crate::multiversion) compiles a function's body three times — for
//! AVX-512, for AVX2 with FMA, and for the baseline — and each call runs the widest clone the
//! CPU supports. The clones compute the same operations in the same order: Rust never
//! contracts `a * b + c` into a fused multiply-add and never reorders float arithmetic, so
//! the compiler may only widen independent element-wise work. Their results are therefore
//! identical to the bit (tests check this for every kernel), and only their speed differs.

use std::cell::Cell;
use std::sync::OnceLock;

/// An instruction-set level a [`multiversion!`](crate::multiversion) function can run at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// Baseline x86-64 (SSE2), or any other architecture.
    Base,
    /// AVX2 with FMA (x86-64-v3).
    Avx2,
    /// AVX-512 F/VL/BW/DQ with AVX2 and FMA (x86-64-v4).
    Avx512,
}

thread_local! {
    static CAP: Cell<Option<Level>> = const { Cell::new(None) };
}

/// The widest level this CPU supports (detected once).
pub fn detected() -> Level {
    static DETECTED: OnceLock<Level> = OnceLock::new();
    *DETECTED.get_or_init(|| {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            let v3 = has!("avx2") && has!("fma");
            if v3 && has!("avx512f") && has!("avx512vl") && has!("avx512bw") && has!("avx512dq") {
                return Level::Avx512;
            }
            if v3 {
                return Level::Avx2;
            }
        }
        Level::Base
    })
}

/// The level kernels run at on this thread: the detected one, or lower under [`with_cap`].
pub fn level() -> Level {
    let d = detected();
    CAP.with(Cell::get).map_or(d, |c| c.min(d))
}

/// Runs `f` with this thread's kernels held at `cap` or below (never above what the CPU
/// has): how tests compare the clones, and how a speed-up is measured on one machine.
pub fn with_cap<R>(cap: Level, f: impl FnOnce() -> R) -> R {
    let before = CAP.with(|c| c.replace(Some(cap)));
    let out = f();
    CAP.with(|c| c.set(before));
    out
}

/// Defines a function whose body is compiled for AVX-512, for AVX2+FMA and for baseline
/// x86-64, and which runs the widest clone that [`level`](crate::policy::kernels::simd::level) allows.
/// Arguments are plain `name: Type` pairs (no patterns, no generics).
#[macro_export]
macro_rules! multiversion {
    ($(#[$attr:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$attr])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            fn base($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
                fn v4($($arg: $ty),*) $(-> $ret)? $body
                #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
                fn v3($($arg: $ty),*) $(-> $ret)? $body
                match $crate::policy::kernels::simd::level() {
                    #[expect(unsafe_code, reason = "level() never exceeds the features the CPU reports")]
                    $crate::policy::kernels::simd::Level::Avx512 => return unsafe { v4($($arg),*) },
                    #[expect(unsafe_code, reason = "level() never exceeds the features the CPU reports")]
                    $crate::policy::kernels::simd::Level::Avx2 => return unsafe { v3($($arg),*) },
                    $crate::policy::kernels::simd::Level::Base => {}
                }
            }
            base($($arg),*)
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    crate::multiversion! {
        fn sum_of_squares(x: &[f32], out: &mut [f32]) -> f32 {
            for (o, v) in out.iter_mut().zip(x) {
                *o = v * v + 0.5;
            }
            out.iter().sum()
        }
    }

    #[test]
    fn caps_never_exceed_the_cpu_and_restore() {
        let d = detected();
        assert_eq!(level(), d);
        with_cap(Level::Base, || assert_eq!(level(), Level::Base));
        with_cap(Level::Avx512, || assert_eq!(level(), d));
        assert_eq!(level(), d);
    }

    #[test]
    fn every_clone_gives_the_same_bits() {
        let x: Vec<f32> = (0..1000).map(|i| (i as f32 * 0.37).sin() * 3.0).collect();
        let run = |cap| {
            with_cap(cap, || {
                let mut out = vec![0.0; x.len()];
                let s = sum_of_squares(&x, &mut out);
                (
                    s.to_bits(),
                    out.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                )
            })
        };
        let base = run(Level::Base);
        assert_eq!(run(Level::Avx2), base);
        assert_eq!(run(Level::Avx512), base);
    }
}
