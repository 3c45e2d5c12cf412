//! `validate`'s compute section: SPU kernels timed on a real PS3, each
//! run as an emulated SPE program charged with this project's rate method
//! — the kernel's instruction count on the SPU's two pipelines (even:
//! arithmetic; odd: loads, stores, shuffles, branches; one of each a cycle
//! when paired), plus the taken branch at the loop's end — beside the
//! published figure; and the same count times the derivation factor the
//! project's derived kernel rates carry (`FITTED_OVER_DERIVED`, the
//! partition's fitted over derived cost), to show which class of code
//! each factor describes. None is held out: the hand-written kernels set
//! the tuned class's factor (fitted), Codeplay's quicksort the paper
//! class's band's low end (bounding: its row says which class factors it
//! admits), and the two compiled kernels ([`compiled`]) the compiled
//! class's factor and band (fitted, shown apart).

use cellbih::cell::{Cell, CellConfig, CellError, CostModel, Cycles};
use cellbih::kernels::rates::{FITTED_OVER_DERIVED, compiled as class};

/// The SPU's cost of a taken branch without a hint: the CBE Programming
/// Handbook's 18-cycle branch-miss penalty (the SPU predicts not taken).
pub const TAKEN_BRANCH: u64 = 18;

/// A kernel timed on hardware and its instruction count.
pub struct Kernel {
    pub what: &'static str,
    pub source: &'static str,
    pub published: f64,
    pub unit: &'static str,
    /// Cycles of one loop iteration by the count: the busier pipeline's
    /// issue slots (an instruction that stalls its pipeline counts its
    /// stall, an operand not ready counts the wait its latency sets), or
    /// for a chain of dependent instructions the sum of their latencies.
    pub body_cycles: u64,
    /// The loop's taken branch: `TAKEN_BRANCH` unhinted, 0 where a hint
    /// (or the chain's own latency) hides it.
    pub branch: u64,
    /// Issue-bound (independent chains, the pipelines full) or
    /// latency-bound (one dependent chain).
    pub bound: &'static str,
    /// Operations one iteration does, in the unit's operations (0: the
    /// figure is cycles an iteration).
    pub ops: u64,
    pub spes: usize,
    /// Relative tolerance of the count model.
    pub tolerance: f64,
}

/// The kernels: cellmark's SPU stress kernels (`benches/cell/spu/*.S`,
/// `engine/spu_shared/spu_dual_kernel.S`, `docs/spu_tuning.md`,
/// `docs/cell_tuning.md`) and SpuTest's reciprocal chain (`task_reacc.c`,
/// its PS3 time in `main.c`); retail PS3, 3.2 GHz, 6 SPEs, aggregate.
/// Pipelines and latencies: GCC's SPU machine description (`spu.md`). The tolerance: IBM's Cell programming tutorial puts
/// well-written SPU kernels at 80–95 % of their issue-limited peak, so the
/// count (which has no stall beyond those it names) may be up to 1/0.8 =
/// 1.25 times the hardware's rate.
pub fn kernels() -> Vec<Kernel> {
    vec![
        Kernel {
            what: "SP fma, 6 chains x 64 unrolled (384 fma + 384 lnop)",
            source: "cellmark spu_fma_kernel.S",
            published: 134.8,
            unit: "GFLOPS",
            // 384 fma (even) beside 384 lnop (odd), then ai (even) beside
            // brnz (odd).
            body_cycles: 385,
            branch: TAKEN_BRANCH,
            bound: "issue",
            ops: 384 * 8,
            spes: 6,
            tolerance: 0.25,
        },
        Kernel {
            what: "DP dfma, 13 chains x 16 unrolled (208 dfma)",
            source: "cellmark spu_dp_fma_kernel.S",
            published: 8.7,
            unit: "GFLOPS",
            // A dfma holds the even pipe 7 cycles (SPU ISA: 6 stall
            // cycles after issue); ai after the last.
            body_cycles: 208 * 7 + 1,
            branch: TAKEN_BRANCH,
            bound: "issue",
            ops: 208 * 4,
            spes: 6,
            tolerance: 0.25,
        },
        Kernel {
            what: "integer mpya, 7 chains x 32 unrolled (224 mpya + 224 lnop)",
            source: "cellmark spu_int_kernel.S",
            published: 130.1,
            unit: "GIOPS",
            body_cycles: 225,
            branch: TAKEN_BRANCH,
            bound: "issue",
            ops: 224 * 8,
            spes: 6,
            tolerance: 0.25,
        },
        Kernel {
            what: "shufb/rotqbi/shlqbi, 64 x 9 odd-pipe ops beside nop",
            source: "cellmark spu_shuf_kernel.S",
            published: 68.43,
            unit: "GOPS",
            body_cycles: 64 * 9 + 1,
            branch: TAKEN_BRANCH,
            bound: "issue",
            ops: 64 * 9 * 4,
            spes: 6,
            tolerance: 0.25,
        },
        Kernel {
            what: "a 12-instruction loop (one even), no branch hint, 1 SPE",
            source: "cellmark spu_branch_kernel.S",
            published: 30.0,
            unit: "cyc/iter",
            // 10 lnop, ai and brnz: no even/odd pair lines up.
            body_cycles: 12,
            branch: TAKEN_BRANCH,
            bound: "issue",
            ops: 0,
            spes: 1,
            tolerance: 0.25,
        },
        Kernel {
            what: "reciprocal and rsqrt, 6 + 6 chains x 8 unrolled (66 even + 12 frest/frsqest)",
            source: "cellmark spu_recip_kernel.S",
            published: 56.43,
            unit: "GOPS",
            // A block: 66 even-pipe instructions beside lnop; frest and
            // frsqest are odd-pipe (GCC's spu.md: "shuf", 4 cycles), so
            // each of the 12 beside an lnop issues alone (+12); fi's
            // 7-cycle latency (spu.md "fp7") meets its user 6 instructions
            // later twice (+2): 80 a block, 8 blocks, then ai/brnz.
            body_cycles: 8 * 80 + 1,
            branch: TAKEN_BRANCH,
            bound: "issue",
            ops: 8 * 264,
            spes: 6,
            tolerance: 0.25,
        },
        Kernel {
            what: "dual issue: 6 fma beside 6 shufb/rotqbi/shlqbi, 64 unrolled",
            source: "cellmark spu_dual_kernel.S",
            published: 202.13,
            unit: "GOPS",
            body_cycles: 64 * 6 + 1,
            branch: TAKEN_BRANCH,
            bound: "issue",
            ops: 64 * 72,
            spes: 6,
            tolerance: 0.25,
        },
        Kernel {
            what: "one dependent chain: frest, fi, fnms, fma (a Newton step), 6 SPEs",
            source: "SpuTest task_reacc.c",
            // 800 M iterations on each SPU in 6125 ms.
            published: 6125e-3 * 3.2e9 / 800e6,
            unit: "cyc/iter",
            // Latencies (spu.md): frest 4, fi 7, fnms 6, fma 6. The loop's
            // counter, compare and hinted branch issue beside the chain.
            body_cycles: 4 + 7 + 6 + 6,
            branch: 0,
            bound: "latency",
            ops: 0,
            spes: 6,
            tolerance: 0.25,
        },
    ]
}

/// The compiled class's kernels: SPU C with intrinsics compiled by
/// spu-lv2-gcc 4.1.1 -O3, all data in the local store, timed by each SPE's
/// decrementer on a retail PS3 (cellmark README §7, `benches/nbody/`;
/// `docs/cell_tuning.md` §5.2, `benches/fft/`). Their counts are derived
/// in `cellbih::kernels::rates::compiled`; they set that class's factor
/// (fitted), and each is returned with the factor it alone gives.
pub fn compiled() -> Vec<(Kernel, u64)> {
    vec![
        (
            Kernel {
                what: "N-body, all pairs, a vector of 4 pairs (12 SP + 1 even, 6 odd)",
                source: "cellmark benches/nbody/spu_nbody_kernel.c",
                published: 2.195,
                unit: "Gpairs/s",
                body_cycles: 13,
                // The loop's branch is hinted (gcc's hbr): in the count.
                branch: 0,
                bound: "latency",
                ops: 4,
                spes: 6,
                tolerance: 0.01,
            },
            class::NBODY_PER_MILLE,
        ),
        (
            Kernel {
                what: "FFT, 4 x 1024 points a batch: 5120 butterflies at 16, the \
                       bit reversal, the stages' loops",
                source: "cellmark benches/fft/spu_fft_kernel.c",
                published: 0.18482,
                unit: "Gpoints/s",
                body_cycles: 5120 * 16 + 1024 * 7 + 1023 * 5,
                branch: 0,
                bound: "latency",
                ops: 4096,
                spes: 6,
                tolerance: 0.01,
            },
            class::FFT_PER_MILLE,
        ),
    ]
}

impl Kernel {
    /// The kernel's figure on `cost`'s machine with its count times
    /// `per_mille` / 1000: each SPE runs the loop, charging each
    /// iteration's cycles.
    pub fn run(&self, cost: &CostModel, per_mille: u64) -> Result<f64, CellError> {
        let iterations = 1000u64;
        let per_iteration = ((self.body_cycles + self.branch) * per_mille).div_ceil(1000);
        let mut cfg = CellConfig::ps3().with_spes(self.spes);
        cfg.cost = cost.clone();
        // Timed inside the SPU program: no start-up.
        cfg.resident = true;
        let mut cell = Cell::new(cfg)?;
        for id in 0..self.spes {
            cell.spawn_spe(id, move |spe| async move {
                for _ in 0..iterations {
                    spe.compute(Cycles(per_iteration));
                }
                Ok(())
            });
        }
        let run = cell.run()?;
        let seconds = run.cycles.0 as f64 / cost.clock_hz;
        Ok(match self.ops {
            0 => run.cycles.0 as f64 / iterations as f64,
            ops => (self.spes as u64 * iterations * ops) as f64 / seconds / 1e9,
        })
    }

    /// The model's figure over the published one, as a slowdown: above 1
    /// the model is slower than the hardware.
    pub fn slower(&self, model: f64) -> f64 {
        match self.ops {
            0 => model / self.published,
            _ => self.published / model,
        }
    }
}

/// The compute section: each kernel's published figure, its count's, and
/// the count times the derivation factor. Returns the rows and the
/// kernels outside their tolerance.
pub fn section(
    cost: &CostModel,
    text: bool,
) -> Result<(Vec<serde_json::Value>, Vec<&'static str>), String> {
    let mut rows = Vec::new();
    let mut failed = Vec::new();
    let title = format!(
        "compute: SPU kernels timed on a PS3 (hand-written: fitted, the tuned class; \
         quicksort: bounding, the paper's); ratio: their count's speed over the hardware's; \
         x{FITTED_OVER_DERIVED}: the count times the paper's factor; ±25 % on the count, \
         on x{FITTED_OVER_DERIVED} for the quicksort"
    );
    if text {
        println!("\n{}", cellbih_cli::report::wrap(&title, 80));
    }
    super::row(
        text,
        "kernel (6 SPEs unless said)",
        ["published", "count", "ratio", "x4", "verdict"].map(String::from),
    );
    for k in kernels() {
        let err = |e: CellError| format!("{}: {e}", k.what);
        let count = k.run(cost, 1000).map_err(err)?;
        let derived = k.run(cost, FITTED_OVER_DERIVED * 1000).map_err(err)?;
        let (slower, slower_derived) = (k.slower(count), k.slower(derived));
        let ok = (slower - 1.0).abs() <= k.tolerance;
        if !ok {
            failed.push(k.what);
        }
        super::row(
            text,
            &format!("{} ({})", k.what, k.unit),
            [
                format!("{:.2}", k.published),
                format!("{count:.2}"),
                format!("{:.3}", 1.0 / slower),
                format!("{:.2}", 1.0 / slower_derived),
                super::verdict(ok),
            ],
        );
        rows.push(serde_json::json!({
            "figure": k.what, "source": k.source, "unit": k.unit,
            "published": k.published, "emulated": count, "ratio": 1.0 / slower,
            "tolerance": k.tolerance, "pass": ok, "role": "fitted",
            "sets": "the tuned class's factor, 1.1 (kernels::rates::Code::Tuned)",
            "section": "compute", "bound": k.bound, "times_derivation_factor": derived,
            "ratio_times_derivation_factor": 1.0 / slower_derived,
        }));
    }
    let (sort_rows, sort_failed) = sorts(cost, text)?;
    rows.extend(sort_rows);
    failed.extend(sort_failed);
    let passed = rows.iter().filter(|r| r["pass"] == true).count();
    if text {
        println!("{passed} of {} pass", rows.len());
    }
    let (compiled_rows, compiled_failed) = compiled_section(cost, text)?;
    rows.extend(compiled_rows);
    failed.extend(compiled_failed);
    Ok((rows, failed))
}

/// Codeplay's quicksort through the software cache, judged in the paper's
/// class: its rows, and those outside the tolerance.
fn sorts(
    cost: &CostModel,
    text: bool,
) -> Result<(Vec<serde_json::Value>, Vec<&'static str>), String> {
    let mut rows = Vec::new();
    let mut failed = Vec::new();
    for t in &super::sorts::SPU {
        let (count, paper) = t.spu(cost).map_err(|e| format!("{}: {e}", t.what))?;
        let (ratio, ratio_paper) = (t.published_ms / count, t.published_ms / paper);
        let ok = (paper / t.published_ms - 1.0).abs() <= 0.25;
        if !ok {
            failed.push(t.what);
        }
        let (low, high) = admitted(count, paper, t.published_ms, 0.25);
        super::row(
            text,
            &format!("{} (ms; admits x{low:.2}-{high:.2})", t.what),
            [
                format!("{:.2}", t.published_ms),
                format!("{count:.2}"),
                format!("{ratio:.3}"),
                format!("{ratio_paper:.2}"),
                super::verdict(ok),
            ],
        );
        rows.push(serde_json::json!({
            "figure": t.what, "source": super::sorts::SOURCE, "unit": "ms",
            "published": t.published_ms, "emulated": paper, "ratio": paper / t.published_ms,
            "tolerance": 0.25, "pass": ok, "role": "bounding",
            "sets": "the paper class's band, its low end (kernels::rates::Code::band)",
            "section": "compute", "bound": "latency", "at_count": count,
            "ratio_at_count": count / t.published_ms, "admits_factor": [low, high],
        }));
    }
    Ok((rows, failed))
}

/// The class factors (times each counted instruction) at which a sort's
/// time lies within `tolerance` of `published`: its time is the software
/// cache's measured costs, which no class moves, plus its counted
/// instructions times the factor — a line through its time at its count
/// (`at_count`) and at 4 times it (`at_four`). Where the cache's share is
/// large the range is wide: the row tells a class apart only that far.
fn admitted(at_count: f64, at_four: f64, published: f64, tolerance: f64) -> (f64, f64) {
    let per_factor = (at_four - at_count) / 3.0;
    let fixed = at_count - per_factor;
    let factor = |ms: f64| (ms - fixed) / per_factor;
    (
        factor(published * (1.0 - tolerance)),
        factor(published * (1.0 + tolerance)),
    )
}

/// The compiled class's kernels: each one's figure at its count, at the
/// factor it alone gives (fitted: it shows the fit took), and at the
/// class's factor (their geometric mean).
fn compiled_section(
    cost: &CostModel,
    text: bool,
) -> Result<(Vec<serde_json::Value>, Vec<&'static str>), String> {
    let factor = class::FACTOR_PER_MILLE as f64 / 1000.0;
    if text {
        let title = format!(
            "compiled: SPU C timed on a PS3, fitted (the class's x{factor:.2} and band); own: \
             the count times its own factor (±1 %)"
        );
        println!("\n{}", cellbih_cli::report::wrap(&title, 80));
    }
    super::row(
        text,
        "kernel (6 SPEs)",
        [
            "published",
            "count",
            "own",
            &format!("x{factor:.2}"),
            "verdict",
        ]
        .map(String::from),
    );
    let mut rows = Vec::new();
    let mut failed = Vec::new();
    for (k, own) in compiled() {
        let err = |e: CellError| format!("{}: {e}", k.what);
        let count = k.run(cost, 1000).map_err(err)?;
        let fitted = k.run(cost, own).map_err(err)?;
        let at_class = k.run(cost, class::FACTOR_PER_MILLE).map_err(err)?;
        let ok = (k.slower(fitted) - 1.0).abs() <= k.tolerance;
        if !ok {
            failed.push(k.what);
        }
        super::row(
            text,
            &format!("{} ({})", k.what, k.unit),
            [
                format!("{:.3}", k.published),
                format!("{count:.3}"),
                format!("{fitted:.3}"),
                format!("{at_class:.3}"),
                super::verdict(ok),
            ],
        );
        rows.push(serde_json::json!({
            "figure": k.what, "source": k.source, "unit": k.unit,
            "published": k.published, "emulated": fitted, "ratio": 1.0 / k.slower(fitted),
            "tolerance": k.tolerance, "pass": ok, "role": "fitted",
            "sets": "the compiled class's factor and band (kernels::rates::compiled)",
            "section": "compute", "bound": k.bound, "at_count": count,
            "at_class_factor": at_class,
        }));
    }
    if text {
        println!("{} of {} pass", rows.len() - failed.len(), rows.len());
    }
    Ok((rows, failed))
}
