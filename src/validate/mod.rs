//! The benchmark's invariants (docs/validate.md). Each check is a function of
//! its inputs so that tests can inject the fault it guards against and see
//! it fail.

mod blind;
mod defensive;
mod forecast;
mod give_way;
mod grid;
mod hedging;
mod late;
mod leaks;
mod learner;
mod motion;

pub use blind::{BlindCell, check_blind_play_loses, check_gap_acceptance, search_blind};
pub use defensive::{DefensiveCell, WaitCell, check_defensive, defensive_readers, reasons_to_wait};
pub use forecast::{ForecastCell, check_forecast, forecast_references};
pub use give_way::{GiveWayCell, check_give_way_time, give_way_time};
pub use grid::{
    check_anti_gaming, check_caution, check_correctness, check_reward_ordering, check_solvable, check_tiers_bite,
};
pub use hedging::{HedgeCell, check_hedging, hedging_drivers, hedging_readers};
pub use late::{LateCell, check_follows_evidence, check_late_reader, late_readers};
pub use leaks::{SceneText, check_hidden_disposition, check_round_trip};
pub use learner::{LearnedCell, check_learned_adversary, learned_adversaries};
pub use motion::{MotionCell, check_motion, road_user_motion};

use crate::adversary::learned;
use crate::baselines::{Cell, CellSummary, GridSpec, run_grid};
use crate::episode::Episode;
use crate::observation::render_scene;
use crate::policy::PolicyKind;
use crate::scenario::{ScenarioKind, ScenarioSet, Tier};
use serde::Serialize;

/// The bars (docs/validate.md).
pub const SOLVABLE_TIER1: f64 = 0.95;
pub const SOLVABLE_ANY: f64 = 0.85;
pub const ANTI_GAMING_MARGIN: f64 = 0.30;
pub const BITE_MARGIN: f64 = 0.30;
pub const TIER1_CUE_FOLLOWER_WITHIN: f64 = 0.20;
pub const EXPERT_CORRECTNESS: f64 = 0.90;
pub const CONSTANT_CORRECTNESS: f64 = 0.60;
pub const FOLLOWS_EVIDENCE: f64 = 0.95;
pub const LATE_READER: f64 = 0.85;
pub const TWO_LATE_READER: f64 = 0.60;
/// The cautious readers' bars: success and collision rate on every cell.
pub const CAUTIOUS_SUCCESS: f64 = 0.85;
pub const CAUTIOUS_COLLISION: f64 = 0.02;
/// The learned adversary's bars: its hack rate at most this above the
/// expert's own, and its masked success at least this below the expert's.
pub const LEARNED_HACK_MARGIN: f64 = 0.02;
pub const LEARNED_MASK_GAP: f64 = 0.30;
/// The longest reading delay the slack measurement tries (decisions).
pub const MAX_SLACK_LAG: usize = 6;
/// The hedging readers' braking levels (m/s^2): every tenth from 1.0 to 1.6.
pub const HEDGE_BRAKES_MPS2: [f64; 7] = [1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6];
/// The scenarios where people hedge from the first decision. On the merge,
/// dropping back on the ramp is itself giving the lane car its turn, so
/// hedging there means easing off only while unsure (`expert_cautious`).
pub const HEDGE_FROM_START: [ScenarioKind; 2] = [ScenarioKind::YieldStandoff, ScenarioKind::PedestrianFeint];
/// Road users move as people do: no pedestrian crosses slower than this
/// (m/s; the 15th percentile of older pedestrians' walking speed is 0.92,
/// of younger ones' 1.15, and the MUTCD's design speed 1.2) ...
pub const SLOWEST_CROSSING_MPS: f64 = 0.9;
/// ... a walker takes at least this long (s) to come to rest from its pace,
/// so that a reading can show it slowing (even a rapid stop on a signal
/// takes young adults 0.46 s from 1.29 m/s, older ones 0.57 s, Tirosh and
/// Sparrow 2004; a planned stop at a kerb is no sharper) ...
pub const QUICKEST_STOP_S: f64 = 0.5;
/// ... a pedestrian who follows another across sets out within this (s)
/// of it, and walks beside it (neighbours of a crossing pedestrian follow
/// it, Faria, Krause and Krause 2010; a group walks abreast at one pace,
/// Moussaïd et al. 2010) ...
pub const WIDEST_FOLLOW_S: f64 = 1.0;
/// ... no car brakes harder than this (m/s^2) on an open road (what
/// lifting off the accelerator slows a car by) ...
pub const OPEN_ROAD_BRAKE_MPS2: f64 = 0.5;
/// A driver who gives way to a road user that really goes first keeps at
/// least this many decisions to spare ...
pub const GIVE_WAY_SPARE_TURNS: u32 = 2;
/// ... in at least this share of those episodes.
pub const GIVE_WAY_SPARE_SHARE: f64 = 0.95;

/// The outcome of one invariant.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Check {
    pub name: &'static str,
    pub pass: bool,
    /// The deciding figure, for the one-line report.
    pub figure: String,
    /// Whether a failure fails `validate`. An invariant the built-in
    /// scenarios are known not to meet yet is reported as OPEN instead
    /// (`validate --strict` makes every check gating).
    pub gating: bool,
}

impl Check {
    fn new(name: &'static str, pass: bool, figure: String) -> Check {
        Check { name, pass, figure, gating: true }
    }

    pub fn line(&self) -> String {
        let status = match (self.pass, self.gating) {
            (true, _) => "PASS",
            (false, true) => "FAIL",
            (false, false) => "OPEN",
        };
        format!("{status:<5} {:<26} {}", self.name, self.figure)
    }

    /// A failure that fails the run.
    pub fn failed(&self) -> bool {
        !self.pass && self.gating
    }
}

fn find(cells: &[CellSummary], scenario: ScenarioKind, tier: Tier, policy: PolicyKind) -> Option<&CellSummary> {
    cells.iter().find(|c| c.cell == Cell { scenario, tier, policy })
}

fn cell_keys(cells: &[CellSummary]) -> Vec<(ScenarioKind, Tier)> {
    let mut keys: Vec<_> = cells.iter().map(|c| (c.cell.scenario, c.cell.tier)).collect();
    keys.sort();
    keys.dedup();
    keys
}

/// Every (scenario, tier) cell of `scenarios` by `tiers`, in that order.
fn cells_of(scenarios: &[ScenarioKind], tiers: &[Tier]) -> Vec<(ScenarioKind, Tier)> {
    scenarios.iter().flat_map(|&s| tiers.iter().map(move |&t| (s, t))).collect()
}

fn label(s: ScenarioKind, t: Tier) -> String {
    format!("{s}/t{t}")
}

/// Invariants the built-in scenarios are known not to meet yet: printed as
/// OPEN, and not failing `validate` unless `strict`. A check goes here only
/// with a note on the issue that tracks it. Today: the way people hedge,
/// and the road users' motion against published human ranges
/// (docs/validate.md gives the figures, the bound that keeps each from
/// holding alongside blind play losing, and the change of design proposed).
pub const OPEN_CHECKS: [&str; 0] = [];

/// What the lines are measured on, gathered once per run: the baseline
/// grid's cells and what it recorded, the seeds, and what two lines share
/// (the blind search, the hidden-disposition check's observations),
/// measured on first use.
pub(crate) struct Run<'a> {
    set: &'a ScenarioSet,
    /// The scenarios checked (`--scenario`): every line reads only these.
    scenarios: Vec<ScenarioKind>,
    seeds: std::ops::Range<u64>,
    search_budget: usize,
    cells: Vec<CellSummary>,
    expert_timings: Vec<crate::episode::EvidenceTiming>,
    /// Per grid cell, the episodes in which a waiting road user started
    /// into an ego that could no longer stop.
    unstoppable: Vec<(Cell, usize)>,
    blind: std::sync::OnceLock<Vec<BlindCell>>,
    hidden: std::sync::OnceLock<(Check, Vec<crate::observation::Observation>)>,
}

impl<'a> Run<'a> {
    /// Play the baseline grid (every built-in policy on every cell, `n`
    /// seeds from `seed_base`) and keep what the lines read of it.
    fn new(
        set: &'a ScenarioSet,
        scenarios: &[ScenarioKind],
        n: usize,
        seed_base: u64,
        search_budget: usize,
    ) -> Run<'a> {
        let spec = GridSpec {
            scenarios: scenarios.to_vec(),
            tiers: Tier::ALL.to_vec(),
            policies: PolicyKind::ALL.to_vec(),
            episodes: n,
            seed_base,
        };
        let expert_timings = std::sync::Mutex::new(Vec::new());
        let unstoppable = std::sync::Mutex::new(Vec::new());
        let cells = run_grid(set, &spec, &|cell, records| {
            if cell.policy == PolicyKind::Expert {
                let mut t = expert_timings.lock().unwrap_or_else(|e| e.into_inner());
                t.extend(records.iter().map(|r| r.timing));
            }
            let n = records.iter().filter(|r| r.grades.diagnostics.unstoppable_turns_taken > 0).count();
            unstoppable.lock().unwrap_or_else(|e| e.into_inner()).push((cell, n));
        });
        let mut unstoppable = unstoppable.into_inner().unwrap_or_else(|e| e.into_inner());
        unstoppable.sort_by_key(|(c, _)| (c.scenario, c.tier, c.policy));
        Run {
            set,
            scenarios: scenarios.to_vec(),
            seeds: seed_base..seed_base + n as u64,
            search_budget,
            cells,
            expert_timings: expert_timings.into_inner().unwrap_or_else(|e| e.into_inner()),
            unstoppable,
            blind: std::sync::OnceLock::new(),
            hidden: std::sync::OnceLock::new(),
        }
    }

    /// The blind-policy search on every cell ("blind play loses" and "road
    /// users accept gaps" both read it).
    fn blind(&self) -> &[BlindCell] {
        self.blind
            .get_or_init(|| search_blind(self.set, &self.scenarios, &Tier::ALL, self.seeds.clone(), self.search_budget))
    }

    /// The hidden-disposition check on what a model is shown (the scene
    /// text and the bytes of the scene's PNG picture), and the observations
    /// it rendered (which the round-trip line parses back).
    fn hidden(&self) -> &(Check, Vec<crate::observation::Observation>) {
        self.hidden.get_or_init(|| {
            let (mut check, observations) =
                check_hidden_disposition(self.set, &self.scenarios, &Tier::ALL, self.seeds.clone(), &|e: &Episode| {
                    let mut shown = render_scene(e.observation());
                    match crate::picture::png(e.observation()) {
                        Ok(png) => shown.extend(png.iter().map(|b| char::from(*b))),
                        Err(err) => shown.push_str(&err.to_string()),
                    }
                    shown
                });
            if check.pass {
                check.figure.push_str(" (scene text and PNG picture)");
            }
            (check, observations)
        })
    }
}

/// One line of `validate`: how it is measured on a run.
type Line = fn(&Run) -> Check;

/// Every line, in the order `validate` prints them: a new line is a file
/// of its own (its measurement, its check and its test hooks) and one
/// entry here.
const LINES: &[Line] = &[
    |run| check_solvable(&run.cells),
    |run| check_anti_gaming(&run.cells),
    |run| check_blind_play_loses(&run.cells, run.blind()),
    |run| {
        let learned =
            learned_adversaries(run.set, &run.scenarios, &Tier::ALL, run.seeds.clone(), learned::DEFAULT_TRAINING);
        check_learned_adversary(&run.cells, &learned)
    },
    |run| check_tiers_bite(&run.cells),
    |run| run.hidden().0.clone(),
    |run| check_round_trip(&run.hidden().1, &render_scene),
    |run| check_reward_ordering(&run.cells),
    |run| check_correctness(&run.cells),
    |run| check_follows_evidence(&run.expert_timings),
    |run| check_late_reader(&late_readers(run.set, &run.scenarios, &Tier::ALL, run.seeds.clone())),
    |run| check_give_way_time(&give_way_time(run.set, &run.scenarios, &Tier::ALL, run.seeds.clone())),
    |run| check_caution(&run.cells),
    |run| check_hedging(&hedging_readers(run.set, &run.scenarios, &Tier::ALL, run.seeds.clone())),
    |run| {
        let defensive = defensive_readers(run.set, &run.scenarios, &Tier::ALL, run.seeds.clone());
        check_defensive(&defensive, &reasons_to_wait(run.set, &run.scenarios, &Tier::ALL, run.seeds.clone()))
    },
    |run| check_gap_acceptance(&run.unstoppable, run.blind()),
    |run| check_motion(&road_user_motion(run.set, &run.scenarios, &Tier::ALL, run.seeds.clone())),
    |run| check_forecast(&forecast_references(run.set, &run.scenarios, &Tier::ALL, run.seeds.clone())),
];

/// Run every invariant on `scenarios` at `n` seeds per cell; the
/// blind-policy search spends `search_budget` episodes per cell. `strict`:
/// every check gates, the open ones included.
pub fn run(
    set: &ScenarioSet,
    scenarios: &[ScenarioKind],
    n: usize,
    seed_base: u64,
    search_budget: usize,
    strict: bool,
) -> Vec<Check> {
    let run = Run::new(set, scenarios, n, seed_base, search_budget);
    let mut checks: Vec<Check> = LINES.iter().map(|line| line(&run)).collect();
    for c in &mut checks {
        c.gating = strict || !OPEN_CHECKS.contains(&c.name);
    }
    checks
}
