//! The options of `raycast` and `render` that cast on the emulated Cell
//! (`--on-cell`), and what they print.

use cellbih::cast::{CacheConfig, CastConfig, Packet, Precision};

use crate::Res;

#[derive(clap::Args)]
pub struct CastArgs {
    /// Cast the rays on the emulated Cell's SPEs (as many as --spes), each
    /// reading the tree through a software cache in its local store: the
    /// same hits as the host's tracer, and their simulated PS3 time.
    #[arg(long)]
    pub on_cell: bool,
    /// --on-cell: write the cast's timeline here as Chrome trace JSON (open
    /// it in ui.perfetto.dev): every SPE's tiles, cache misses and waits.
    #[arg(long)]
    pub trace: Option<std::path::PathBuf>,
    #[command(flatten)]
    pub cache: CacheArgs,
}

/// How the SPEs cast: their software cache, tiles and charged arithmetic.
#[derive(clap::Args)]
pub struct CacheArgs {
    /// Casting on the Cell: the software cache's size in each local store,
    /// KiB (1 to 128) [default: 32]
    #[arg(long, value_parser = crate::args::between::<u32, _>(1..=128))]
    pub cache_kib: Option<u32>,
    /// Casting on the Cell: the software cache's lines per set (1 to 16)
    /// [default: 4]
    #[arg(long, value_parser = crate::args::between::<u32, _>(1..=16))]
    pub cache_ways: Option<u32>,
    /// Casting on the Cell: consecutive 128-byte lines one cache miss
    /// fetches in one get (1 to 128; Bullet's SPU code fetched 2 KiB, 16
    /// lines) [default: 1]
    #[arg(long, value_parser = crate::args::between::<u32, _>(1..=128))]
    pub fetch_lines: Option<u32>,
    /// Casting on the Cell: rays an SPE takes at a time from the shared
    /// tile counter (1 to 256) [default: 64]
    #[arg(long, value_parser = crate::args::between::<u32, _>(1..=256))]
    pub tile_rays: Option<u32>,
    /// Casting on the Cell: the arithmetic the SPEs are charged for:
    /// single (single-precision SIMD, as Cell ray tracers ran) or double
    /// (what the emulation computes; a double-precision instruction issues
    /// once every 7 cycles on the PS3's SPU). The hits are the same
    /// [default: single]
    #[arg(long, value_enum)]
    pub precision: Option<PrecisionArg>,
    /// Casting on the Cell: rays each SPE keeps in flight (1 to 16): with
    /// more than one, a ray whose cache line is on its way yields to
    /// another (Benthin et al. 2006's "software hyperthreading"); with
    /// one, the SPE waits for each miss [default: 1]
    #[arg(long, value_parser = crate::args::between::<u32, _>(1..=16))]
    pub rays_in_flight: Option<u32>,
    /// Casting on the Cell: rays traced together as one packet, W×H of
    /// the image (each 1 to 8; e.g. 4x4): one traversal, each node and
    /// triangle read once for the packet and tested four rays a SIMD
    /// vector (Benthin et al. 2006); a packet whose directions differ in
    /// sign is cast ray by ray; the same hits. 1x1: every ray alone
    /// [default: 4x4]
    #[arg(long, value_parser = Packet::parse)]
    pub packet: Option<Packet>,
}

/// `--precision`.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum PrecisionArg {
    Single,
    Double,
}

impl CastArgs {
    /// The cast's configuration with `--on-cell`, `None` without; an
    /// option of the Cell's cast given without `--on-cell` is an error
    /// that names it, and so is a trace of an untimed cast (`timed`:
    /// whether the Cell's mode keeps time), one that cannot be written, or
    /// one sent to the standard output where `out` (the hits or the image)
    /// already goes; and an output that would replace one of `inputs`.
    pub fn config(
        &self,
        timed: bool,
        out: &std::path::Path,
        inputs: &[(&str, &std::path::Path)],
    ) -> Res<Option<CastConfig>> {
        let trace = self.trace.as_deref().filter(|_| self.on_cell);
        let outputs: Vec<(&str, &std::path::Path)> = [("--out", out)]
            .into_iter()
            .chain(trace.map(|t| ("--trace", t)))
            .collect();
        crate::output::check_files(&outputs, inputs)?;
        if self.on_cell {
            if let Some(path) = &self.trace {
                if !timed {
                    return Err("--trace: --mode functional keeps no timeline".into());
                }
                crate::output::check_writable(path)?;
            }
            return Ok(Some(self.cache.config()?));
        }
        if self.trace.is_some() {
            return Err(
                "--trace applies to --on-cell only (a build's trace: cellbih build --trace)".into(),
            );
        }
        match self.cache.first_given() {
            Some(name) => Err(format!("{name} applies to --on-cell only").into()),
            None => Ok(None),
        }
    }
}

impl CacheArgs {
    /// The first of these options given, by name.
    fn first_given(&self) -> Option<&'static str> {
        [
            ("--cache-kib", self.cache_kib.is_some()),
            ("--cache-ways", self.cache_ways.is_some()),
            ("--fetch-lines", self.fetch_lines.is_some()),
            ("--tile-rays", self.tile_rays.is_some()),
            ("--precision", self.precision.is_some()),
            ("--rays-in-flight", self.rays_in_flight.is_some()),
            ("--packet", self.packet.is_some()),
        ]
        .into_iter()
        .find_map(|(name, given)| given.then_some(name))
    }

    /// The cast's configuration: the defaults and what is given; a cache
    /// shape that does not divide into whole sets is an error.
    pub fn config(&self) -> Res<CastConfig> {
        let d = CastConfig::DEFAULT;
        let cfg = CastConfig {
            cache: CacheConfig {
                kib: self.cache_kib.unwrap_or(d.cache.kib),
                ways: self.cache_ways.unwrap_or(d.cache.ways),
                fetch_lines: self.fetch_lines.unwrap_or(d.cache.fetch_lines),
            },
            tile_rays: self.tile_rays.unwrap_or(d.tile_rays),
            precision: match self.precision {
                None => d.precision,
                Some(PrecisionArg::Single) => Precision::Single,
                Some(PrecisionArg::Double) => Precision::Double,
            },
            rays_in_flight: self.rays_in_flight.unwrap_or(d.rays_in_flight),
            packet: self.packet.unwrap_or(d.packet),
            rates: d.rates,
        };
        cfg.cache.sets().map_err(crate::usage)?;
        if !cfg.tile_rays.is_multiple_of(cfg.packet.rays()) {
            return Err(crate::usage(format!(
                "--packet {}: a tile's {} (--tile-rays) must be a whole number of packets",
                cfg.packet,
                cellbih::words::count(cfg.tile_rays as u64, "ray")
            )));
        }
        Ok(cfg)
    }
}
