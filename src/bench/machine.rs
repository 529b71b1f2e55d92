//! The machine a `lente bench` run measured: its CPU, how many logical
//! CPUs it has, and which SIMD extensions the CPU reports. The ratios
//! against Mitsuba's LLVM variant depend in part on the last: Dr.Jit
//! vectorises every stage to the widest extension (16 lanes with
//! AVX-512F, 8 with AVX2), while lente's hand-written lanes are AVX2's
//! eight or four (its BVH walks run in AVX-512VL's 256-bit form where the
//! CPU has it: more registers and mask registers, not more lanes) (on an
//! AVX2 CPU, 8 lanes instead of 4 made Dr.Jit 1.11x faster on the
//! suite's geometric mean: `scripts/llvm_lanes.py`). Printed before the
//! figures so that a table is never read without its machine.

/// What a bench run prints about its machine.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Machine {
    /// The CPU's model name (`/proc/cpuinfo`), or "unknown CPU".
    pub cpu: String,
    /// Logical CPUs this process may run on.
    pub logical_cpus: usize,
    /// Whether the CPU reports AVX (8 float lanes for Dr.Jit).
    pub avx: bool,
    /// Whether the CPU reports AVX2 (lente's SIMD paths).
    pub avx2: bool,
    /// Whether the CPU reports AVX-512F (Dr.Jit's 16 lanes).
    pub avx512f: bool,
    /// Whether lente's BVH walks run in AVX-512VL's form
    /// ([`crate::geometry::PacketIsa`]).
    pub walks_avx512vl: bool,
    /// Whether its packets of sixteen rays run in AVX-512's sixteen lanes
    /// (`PacketIsa::Avx512`) rather than as two of eight.
    pub packets_of_16: bool,
}

impl Machine {
    /// The machine this process runs on.
    pub fn detect() -> Machine {
        let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        #[cfg(target_arch = "x86_64")]
        let (avx, avx2, avx512f) = (
            std::arch::is_x86_feature_detected!("avx"),
            std::arch::is_x86_feature_detected!("avx2"),
            std::arch::is_x86_feature_detected!("avx512f"),
        );
        #[cfg(not(target_arch = "x86_64"))]
        let (avx, avx2, avx512f) = (false, false, false);
        #[cfg(target_arch = "x86_64")]
        let (walks_avx512vl, packets_of_16) = {
            use crate::geometry::PacketIsa;
            let isa = PacketIsa::detect();
            (
                isa.is_some_and(PacketIsa::has_avx512vl),
                isa == Some(PacketIsa::Avx512),
            )
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (walks_avx512vl, packets_of_16) = (false, false);
        Machine {
            cpu: model_name(&cpuinfo).unwrap_or("unknown CPU").to_string(),
            logical_cpus: std::thread::available_parallelism().map_or(1, |n| n.get()),
            avx,
            avx2,
            avx512f,
            walks_avx512vl,
            packets_of_16,
        }
    }

    /// One line: the CPU, its logical CPUs, and its SIMD extensions with
    /// what each renderer runs on them.
    pub fn describe(&self) -> String {
        let yes_no = |b: bool| if b { "yes" } else { "no" };
        let lanes = if self.avx512f {
            "16"
        } else if self.avx {
            "8"
        } else {
            "4"
        };
        format!(
            "machine: {}, {} logical CPU(s); AVX2 {}, AVX-512F {} \
             (lente's SIMD paths: {}; Dr.Jit's LLVM lanes here: {lanes})",
            self.cpu,
            self.logical_cpus,
            yes_no(self.avx2),
            yes_no(self.avx512f),
            match (self.avx2, self.walks_avx512vl, self.packets_of_16) {
                (true, true, true) => "AVX2, BVH walks AVX-512VL, packets of 16 rays in AVX-512",
                (true, true, false) => "AVX2, BVH walks AVX-512VL",
                (true, false, _) => "AVX2",
                _ => "portable",
            },
        )
    }
}

/// The first `model name` of a `/proc/cpuinfo` text (x86; other
/// architectures name it differently and get `None`).
fn model_name(cpuinfo: &str) -> Option<&str> {
    cpuinfo.lines().find_map(|line| {
        let (key, value) = line.split_once(':')?;
        (key.trim() == "model name")
            .then(|| value.trim())
            .filter(|v| !v.is_empty())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_name_is_the_first_cpus() {
        let info = "processor\t: 0\nvendor_id\t: AuthenticAMD\n\
                    model name\t: AMD EPYC 7B13\nflags\t\t: fpu avx2\n\n\
                    processor\t: 1\nmodel name\t: Other\n";
        assert_eq!(model_name(info), Some("AMD EPYC 7B13"));
        assert_eq!(model_name("processor\t: 0\nmodel name\t:   \n"), None);
        assert_eq!(model_name(""), None);
    }

    #[test]
    fn description_names_the_lanes_of_each_extension() {
        let mut m = Machine {
            cpu: "Test CPU".into(),
            logical_cpus: 2,
            avx: true,
            avx2: true,
            avx512f: false,
            walks_avx512vl: false,
            packets_of_16: false,
        };
        let d = m.describe();
        assert!(d.contains("Test CPU, 2 logical CPU(s)"), "{d}");
        assert!(d.contains("AVX2 yes, AVX-512F no"), "{d}");
        assert!(
            d.contains("paths: AVX2;") && d.ends_with("lanes here: 8)"),
            "{d}"
        );
        m.avx512f = true;
        assert!(m.describe().ends_with("lanes here: 16)"));
        m.walks_avx512vl = true;
        assert!(m.describe().contains("paths: AVX2, BVH walks AVX-512VL;"));
        m.packets_of_16 = true;
        let d = m.describe();
        assert!(
            d.contains("walks AVX-512VL, packets of 16 rays in AVX-512;"),
            "{d}"
        );
        (m.walks_avx512vl, m.packets_of_16) = (false, false);
        m.avx = false;
        m.avx2 = false;
        m.avx512f = false;
        let d = m.describe();
        assert!(
            d.contains("paths: portable;") && d.ends_with("lanes here: 4)"),
            "{d}"
        );
    }

    #[test]
    fn detects_this_machine() {
        let m = Machine::detect();
        assert!(m.logical_cpus >= 1);
        assert!(!m.cpu.is_empty());
        // Each extension implies the one before it on every CPU shipped.
        assert!(!m.avx512f || m.avx2);
        assert!(!m.avx2 || m.avx);
        assert!(!m.walks_avx512vl || m.avx512f);
        assert!(!m.packets_of_16 || m.walks_avx512vl);
    }
}
