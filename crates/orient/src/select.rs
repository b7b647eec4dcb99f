//! [`select_orientations`]: the whole of seed 000 §3.1, with the paper's plain greedy
//! kept as a baseline and a stronger search as the default.

use std::time::Instant;

use rand::SeedableRng;
use rand::rngs::StdRng;
use s2g_geom::{Mesh, MeshIndex, Point3, Real, Setup, UnitVector3, sample_surface};

use crate::cover::{SearchOptions, greedy, greedy_order, multi_start_search, prefer_axes};
use crate::directions::{candidate_directions, cone_directions, random_direction};
use crate::error::{OrientError, Result};
use crate::stock::{StockRemovalOptions, StockRemovalReport, StockSamples, improve_for_stock, left};
use crate::tool_reach::ToolReach;
use crate::visibility::{VisibilityContext, VisibilityMatrix, VisibilityOptions, popcount};

/// How the directions are chosen from the candidates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Strategy {
    /// The paper's greedy set cover (Eq. 3), nothing more: the named baseline.
    PlainGreedy,
    /// Greedy, then multi-start swap search over the candidates (starts: greedy, the
    /// best axes, seeded random sets; iterated local search), then continuous
    /// refinement of each direction on the sphere. The default.
    #[default]
    LocalSearch,
}

/// Continuous refinement of the chosen directions (off the candidate lattice).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineOptions {
    /// Whether to refine at all. Default `true` (only used by [`Strategy::LocalSearch`]).
    pub enabled: bool,
    /// Half-angle of the first cone of trial directions around a chosen one, degrees.
    /// Default `4.0` (about half the spacing of 512 candidates).
    pub initial_angle_deg: Real,
    /// The cone is halved after a round without improvement and refinement of that
    /// direction stops below this angle, degrees. Default `0.5`.
    pub min_angle_deg: Real,
    /// Trial directions per cone. Default `6`.
    pub trials_per_cone: usize,
    /// Passes over all chosen directions (stops early when a pass improves nothing).
    /// Default `2`.
    pub passes: usize,
}

impl Default for RefineOptions {
    fn default() -> Self {
        Self { enabled: true, initial_angle_deg: 4.0, min_angle_deg: 0.5, trials_per_cone: 6, passes: 2 }
    }
}

/// Options of [`select_orientations`]; every default is the paper's setting or ours.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientOptions {
    /// Surface samples (area-weighted). Default `16384` (the paper's).
    pub points: usize,
    /// Fibonacci candidate directions; the six axes are always added. Default `512`.
    pub candidates: usize,
    /// Most setups to choose. Default `5` (the paper's Table 2).
    pub max_setups: usize,
    /// Stop adding setups once this fraction of samples is covered. Default `0.99`.
    pub coverage_target: Real,
    /// Seed of sampling, searches and random baselines. Default `0`.
    pub seed: u64,
    /// Selection strategy. Default [`Strategy::LocalSearch`].
    pub strategy: Strategy,
    /// Tool-aware visibility: ball-end radius in part units (see
    /// [`VisibilityOptions::tool_radius`]). Default `None` (the paper's single ray).
    pub tool_radius: Option<Real>,
    /// Offset rays in tool-aware mode. Default `8`.
    pub tool_rays: usize,
    /// Ray origin offset along the normal, relative to the bounding-box diagonal. Default `1e-5`.
    pub ray_eps: Real,
    /// Front-facing threshold: visible only when `n . v > min_cos`. Default `0.0`.
    pub min_cos: Real,
    /// Multi-start search settings (its `seed` is replaced by [`OrientOptions::seed`]).
    pub search: SearchOptions,
    /// Continuous refinement settings.
    pub refine: RefineOptions,
    /// Trials averaged for the random-direction baselines; `0` skips them. Default `10`.
    pub baseline_trials: usize,
    /// The stock-removal term, used by [`select_orientations_in_stock`] only.
    pub stock_removal: StockRemovalOptions,
    /// How deep the tools reach into the stock ([`VisibilityOptions::reach`]): samples of
    /// the surface, and of the stock's material, deeper than that below the stock's top
    /// along a direction are not reached from it. Default `None` (unlimited).
    pub reach: Option<ToolReach>,
}

impl Default for OrientOptions {
    fn default() -> Self {
        Self {
            points: 16384,
            candidates: 512,
            max_setups: 5,
            coverage_target: 0.99,
            seed: 0,
            strategy: Strategy::LocalSearch,
            tool_radius: None,
            tool_rays: 8,
            ray_eps: 1e-5,
            min_cos: 0.0,
            search: SearchOptions::default(),
            refine: RefineOptions::default(),
            baseline_trials: 10,
            stock_removal: StockRemovalOptions::default(),
            reach: None,
        }
    }
}

impl OrientOptions {
    /// The visibility rule these options describe.
    pub fn visibility(&self) -> VisibilityOptions {
        VisibilityOptions {
            eps: self.ray_eps,
            min_cos: self.min_cos,
            tool_radius: self.tool_radius,
            tool_rays: self.tool_rays,
            reach: self.reach,
            ..VisibilityOptions::default()
        }
    }

    fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(OrientError::InvalidArgument(m));
        if self.points == 0 {
            return bad("points must be at least 1".into());
        }
        if self.max_setups == 0 {
            return bad("max_setups must be at least 1".into());
        }
        if !(self.coverage_target > 0.0 && self.coverage_target <= 1.0) {
            return bad(format!("coverage target must be in (0, 1], got {}", self.coverage_target));
        }
        let r = &self.refine;
        if r.enabled
            && !(r.initial_angle_deg.is_finite()
                && r.min_angle_deg > 0.0
                && r.initial_angle_deg >= r.min_angle_deg
                && r.initial_angle_deg < 90.0)
        {
            return bad(format!(
                "refinement angles must satisfy 0 < min <= initial < 90 degrees, got {} and {}",
                r.min_angle_deg, r.initial_angle_deg
            ));
        }
        Ok(())
    }
}

/// Coverage of the Table 2 baselines, as fractions of the samples.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Baselines {
    /// The six principal axes together.
    pub six_axes: Real,
    /// Five uniformly random directions, averaged over `baseline_trials` seeds (0 when skipped).
    pub random5: Real,
    /// Six uniformly random directions, averaged likewise (0 when skipped).
    pub random6: Real,
    /// The paper's plain greedy with the same target and setup limit.
    pub plain_greedy: Real,
    /// Plain greedy's coverage after each pick.
    pub plain_greedy_curve: Vec<Real>,
    /// Plain greedy's directions, in pick order.
    pub plain_greedy_directions: Vec<UnitVector3>,
    /// The multi-start swap search over the candidates, before continuous refinement
    /// (equals `plain_greedy` for [`Strategy::PlainGreedy`]).
    pub swap_search: Real,
}

/// Wall-clock seconds per stage. The only part of a result that varies between runs:
/// drop it when comparing results.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StageTimes {
    /// Surface sampling.
    pub sampling: f64,
    /// BVH construction.
    pub index: f64,
    /// Visibility matrix over the candidates.
    pub visibility: f64,
    /// Greedy and multi-start swap search.
    pub search: f64,
    /// Continuous refinement (including its ray casts).
    pub refine: f64,
    /// Baselines (random directions' ray casts).
    pub baselines: f64,
    /// Everything.
    pub total: f64,
}

/// What [`select_orientations`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct OrientationResult {
    /// Tool axes (part towards spindle), the one covering most first.
    pub directions: Vec<UnitVector3>,
    /// One setup per direction (`Setup::from_direction`), same order.
    pub setups: Vec<Setup>,
    /// Fraction of samples covered after each pick, same order (non-decreasing).
    pub coverage: Vec<Real>,
    /// Fraction of samples visible from any candidate.
    pub upper_bound: Real,
    /// The baselines, measured on the same samples.
    pub baselines: Baselines,
    /// Time per stage (varies between runs; everything else is deterministic).
    pub stage_seconds: StageTimes,
    /// What the stock-removal term found ([`select_orientations_in_stock`]); `None` from
    /// [`select_orientations`], which knows no stock.
    pub stock: Option<StockRemovalReport>,
}

impl OrientationResult {
    /// Final coverage (0 without directions).
    pub fn final_coverage(&self) -> Real {
        self.coverage.last().copied().unwrap_or(0.0)
    }
}

/// Chooses tool orientations for `mesh` (seed 000 §3.1): samples the surface, casts
/// visibility rays from every sample towards every candidate direction, and covers the
/// samples with at most `max_setups` directions ([`Strategy`]). Deterministic for a
/// given mesh and options (except [`OrientationResult::stage_seconds`]).
///
/// When no sample is visible from any candidate (e.g. an inside-out mesh), the result
/// falls back to the single top setup (+Z) with coverage 0.
///
/// Errors: an empty or zero-area mesh, invalid options.
pub fn select_orientations(mesh: &Mesh, opts: &OrientOptions) -> Result<OrientationResult> {
    select_orientations_in_stock(mesh, &[], opts)
}

/// [`select_orientations`] with the stock-removal term ([`crate::stock`]): `stock` holds
/// sample points of the stock body (e.g. [`stock_grid_points`](crate::stock_grid_points));
/// those outside the part are its material. When the setups chosen for visibility leave
/// more removable material than [`StockRemovalOptions::max_left`] allows, directions are
/// swapped for others, or added up to [`OrientOptions::max_setups`], that leave less,
/// without covering fewer samples than the chosen setups or the coverage target, whichever
/// is less. Otherwise the result is [`select_orientations`]'s, plus
/// [`OrientationResult::stock`]. An empty `stock` is [`select_orientations`].
pub fn select_orientations_in_stock(
    mesh: &Mesh,
    stock: &[Point3],
    opts: &OrientOptions,
) -> Result<OrientationResult> {
    let t_total = Instant::now();
    opts.validate()?;
    if mesh.is_empty() {
        return Err(OrientError::NoSurface("the mesh has no triangles".into()));
    }
    if mesh.bbox().is_none() {
        return Err(OrientError::NoSurface("the mesh has no vertices".into()));
    }
    let mut times = StageTimes::default();

    let t = Instant::now();
    // Morton order: consecutive rays of a direction start near each other and walk the
    // same BVH nodes (visibility about 1.3x faster than in the sampler's random order).
    let samples = sample_surface(mesh, opts.points, opts.seed)?.spatially_ordered();
    times.sampling = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let index = MeshIndex::new(mesh)?;
    times.index = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let ctx = VisibilityContext::new(mesh, &index, &samples, &opts.visibility())?;
    let mut m = ctx.matrix(&candidate_directions(opts.candidates));
    times.visibility = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let all: Vec<usize> = (0..m.len()).collect();
    let axes: Vec<usize> = (0..6).collect();
    let target = coverage_target(opts, &m);
    let plain = greedy(&m, &all, opts.max_setups, target);
    let (_, plain_curve) = greedy_order(&m, &plain);
    let plain_cov = m.coverage(&plain);
    let mut chosen = plain.clone();
    if opts.strategy == Strategy::LocalSearch && !plain.is_empty() {
        let search = SearchOptions { seed: opts.seed, ..opts.search };
        let mut k = plain.len();
        chosen = multi_start_search(&m, &all, &axes, &plain, k, &search).0;
        // The target was met: try with fewer setups while it still is.
        while k > 1 && m.coverage(&chosen) >= target {
            let fewer = multi_start_search(&m, &all, &axes, &plain, k - 1, &search).0;
            if m.coverage(&fewer) < target {
                break;
            }
            chosen = fewer;
            k -= 1;
        }
    }
    let swap_cov = m.coverage(&chosen);
    times.search = t.elapsed().as_secs_f64();

    let t = Instant::now();
    if opts.strategy == Strategy::LocalSearch && opts.refine.enabled && !chosen.is_empty() {
        refine(&ctx, &mut m, &mut chosen, &opts.refine);
    }
    if opts.reach.is_some_and(|r| !r.tools().is_empty()) {
        prefer_axes(&m, &mut chosen, &axes, target);
    }
    times.refine = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let stock = if stock.is_empty() {
        None
    } else {
        let diag = mesh.bbox().map_or(1.0, |b| b.extent().norm());
        let samples = StockSamples::new(&index, mesh.vertices(), stock, diag, opts.reach);
        Some(stock_term(&samples, &m, &mut chosen, opts, target)?)
    };
    times.search += t.elapsed().as_secs_f64();

    let t = Instant::now();
    let (random5, random6) = random_baselines(&ctx, opts.baseline_trials, opts.seed);
    times.baselines = t.elapsed().as_secs_f64();

    let upper_bound = m.upper_bound();
    let (order, mut coverage) = greedy_order(&m, &chosen);
    let mut directions: Vec<UnitVector3> = order.iter().map(|&d| m.directions()[d]).collect();
    if directions.is_empty() {
        directions.push(UnitVector3::new_unchecked(s2g_geom::Vector3::z()));
        coverage.push(0.0);
    }
    let setups = directions.iter().map(Setup::from_direction).collect();
    times.total = t_total.elapsed().as_secs_f64();
    Ok(OrientationResult {
        directions,
        setups,
        coverage,
        upper_bound,
        baselines: Baselines {
            six_axes: m.coverage(&axes),
            random5,
            random6,
            plain_greedy: plain_cov,
            plain_greedy_curve: plain_curve,
            plain_greedy_directions: plain.iter().map(|&d| m.directions()[d]).collect(),
            swap_search: swap_cov,
        },
        stage_seconds: times,
        stock,
    })
}

/// The share of the samples the setups are chosen to cover: the options' target, of the
/// samples some candidate reaches where the reach is tool-aware ([`ToolReach::of_tools`]):
/// a sample no tool that fits reaches from any direction (a square inner corner, a hole
/// narrower than every tool) adds no setup, where under the paper's rule every sample
/// counts (and its outputs stay as they were).
fn coverage_target(opts: &OrientOptions, m: &VisibilityMatrix) -> Real {
    match opts.reach {
        Some(r) if !r.tools().is_empty() => opts.coverage_target * m.upper_bound(),
        _ => opts.coverage_target,
    }
}

/// The stock-removal term: measures what `chosen` leaves of the stock's material and,
/// when that is too much, changes the setups ([`improve_for_stock`]).
fn stock_term(
    samples: &StockSamples<'_>,
    m: &VisibilityMatrix,
    chosen: &mut Vec<usize>,
    opts: &OrientOptions,
    target: Real,
) -> Result<StockRemovalReport> {
    let material = samples.material();
    let allowed = (opts.stock_removal.max_left * samples.part() as Real).floor() as usize;
    let mut report = StockRemovalReport { material, part: samples.part(), ..Default::default() };
    // The chosen setups' rows first: most parts leave nothing, and need no more rays.
    let dirs: Vec<UnitVector3> = chosen.iter().map(|&d| m.directions()[d]).collect();
    let mine = samples.matrix(&dirs)?;
    report.left_by_visibility = left(&mine, &(0..mine.len()).collect::<Vec<_>>());
    report.left = report.left_by_visibility;
    if report.left_by_visibility <= allowed || chosen.is_empty() {
        return Ok(report);
    }
    let r = samples.matrix(m.directions())?;
    report.unreachable = left(&r, &(0..r.len()).collect::<Vec<_>>());
    let covered = m.covered(chosen);
    let target = (target * m.points() as Real).ceil() as usize;
    let better = improve_for_stock(m, &r, chosen, opts.max_setups, covered.min(target), allowed);
    report.left = left(&r, &better);
    report.changed = better != *chosen;
    *chosen = better;
    Ok(report)
}

/// Continuous refinement: moves each chosen direction to the best of a cone of trial
/// directions around it while that covers more samples (the others fixed), halving the
/// cone when nothing improves. Trial rows are cast on the fly and appended to `m`.
fn refine(ctx: &VisibilityContext<'_>, m: &mut VisibilityMatrix, chosen: &mut [usize], opts: &RefineOptions) {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let trials = opts.trials_per_cone.max(1);
    for _ in 0..opts.passes {
        let mut improved = false;
        for pos in 0..chosen.len() {
            let others: Vec<usize> =
                chosen.iter().enumerate().filter(|&(q, _)| q != pos).map(|(_, &d)| d).collect();
            let base = m.union(&others);
            let score = |row: &[u64]| -> usize {
                base.iter().zip(row).map(|(a, b)| (a | b).count_ones() as usize).sum()
            };
            let mut current = score(m.row(chosen[pos]));
            let mut angle = opts.initial_angle_deg.to_radians();
            let mut level = 0usize;
            while angle >= opts.min_angle_deg.to_radians() {
                let center = m.directions()[chosen[pos]];
                let dirs = cone_directions(&center, angle, trials, golden * level as Real);
                level += 1;
                // Only samples the other directions miss can change the score.
                let rows: Vec<Vec<u64>> = dirs.iter().filter_map(|d| ctx.row_masked(d, &base).ok()).collect();
                let best = rows.iter().enumerate().map(|(j, r)| (score(r), j)).fold(
                    None,
                    |b: Option<(usize, usize)>, x| if b.is_none_or(|b| x.0 > b.0) { Some(x) } else { b },
                );
                match best {
                    Some((s, j)) if s > current => {
                        // The trial row is partial (masked); store the full row, which later
                        // positions' unions need. `push` only fails on a length mismatch,
                        // impossible for rows of the same context.
                        if let Ok(idx) = m.push(dirs[j], &ctx.row(&dirs[j])) {
                            chosen[pos] = idx;
                            current = s;
                            improved = true;
                        } else {
                            break;
                        }
                    }
                    _ => angle *= 0.5,
                }
            }
        }
        if !improved {
            break;
        }
    }
}

/// Mean coverage of 5 and of 6 uniformly random directions over `trials` seeded trials
/// (the 6-direction set of a trial extends its 5-direction set by one more).
fn random_baselines(ctx: &VisibilityContext<'_>, trials: usize, seed: u64) -> (Real, Real) {
    if trials == 0 {
        return (0.0, 0.0);
    }
    let mut dirs = Vec::with_capacity(6 * trials);
    for t in 0..trials as u64 {
        let mut rng = StdRng::seed_from_u64(seed ^ 0x0ba5_e11e_u64.wrapping_mul(t + 1));
        dirs.extend((0..6).map(|_| random_direction(&mut rng)));
    }
    let (mut r5, mut r6) = (0.0, 0.0);
    let n = ctx.len().max(1) as Real;
    for set in dirs.chunks(6) {
        // Incremental union: each direction only casts rays for samples not yet covered.
        let mut covered = vec![0u64; ctx.words()];
        for (i, d) in set.iter().enumerate() {
            if let Ok(row) = ctx.row_masked(d, &covered) {
                covered.iter_mut().zip(&row).for_each(|(c, r)| *c |= r);
            }
            if i == 4 {
                r5 += popcount(&covered) as Real / n;
            }
        }
        r6 += popcount(&covered) as Real / n;
    }
    (r5 / trials as Real, r6 / trials as Real)
}
