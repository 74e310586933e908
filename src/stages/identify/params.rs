//! The `identify` kind's params ([`Params`], declared once), with the
//! names they accept: strategies ([`StrategyName`]) and optimizers
//! ([`OptimizerName`], the stage's one list of them). The settings of the
//! identification they make are in [`super::spec`].

use crate::identify::frf_refinement::FrfRefinementParams;
use crate::identify::{GuidedParams, Uncertainty, Weights};
use crate::optimize::{OptimizeError, Optimizer};
use crate::pairing::Pairing;
use crate::stages::params::TypeName;
use crate::stages::{ParamProblem, Range};
use serde::{Deserialize, Deserializer, Serialize};
use serde_yaml_ng::{Mapping, Value};

crate::string_enum! {
    /// How parameters are identified.
    pub enum StrategyName {
        BlackBox = "black_box",
        SensitivityGuided = "sensitivity_guided",
    }
}

crate::string_enum! {
    /// The optimizer of a black-box identification.
    pub enum OptimizerName {
        Slsqp = "slsqp",
        Pso = "pso",
        Ga = "ga",
    }
}

/// The optimizer of every subproblem of a sensitivity-guided
/// identification (PUB3: SLSQP per subproblem).
pub const GUIDED_OPTIMIZER: OptimizerName = OptimizerName::Slsqp;

impl OptimizerName {
    /// The optimizer this name stands for with `settings` (the
    /// `optimizer_settings` mapping; `None`: the defaults), or what is wrong
    /// with them: the one place the stage's names meet the optimizers'.
    pub fn optimizer(self, settings: Option<&Mapping>) -> Result<Optimizer, OptimizeError> {
        let settings = settings.cloned().map(Value::Mapping);
        Optimizer::from_settings(self.as_str(), settings.as_ref())
    }
}

/// A settings mapping deserialized into `T`, remembering which keys were
/// written (so a kind default can differ from the type's default).
#[derive(Clone, Debug, Serialize)]
#[serde(transparent)]
pub struct Given<T> {
    pub value: T,
    #[serde(skip)]
    pub keys: Vec<String>,
}

impl<T: Default> Default for Given<T> {
    fn default() -> Self {
        Given {
            value: T::default(),
            keys: Vec::new(),
        }
    }
}

/// Identification's pairing window: a model 30 % off moves modes by up to
/// 20 %.
pub const PAIRING_WINDOW: f64 = 0.3;
/// Identification's smallest MAC of a pair: below it a pair is no evidence
/// of one physical mode.
pub const PAIRING_MIN_MAC: f64 = 0.5;

/// The `pairing` default as `modalflow kinds` prints it: identification's
/// own window and MAC floor ([`PAIRING_WINDOW`], [`PAIRING_MIN_MAC`]), the
/// rest [`Pairing::default`].
fn default_pairing() -> Given<Pairing> {
    Given {
        value: Pairing {
            window: PAIRING_WINDOW,
            min_mac: PAIRING_MIN_MAC,
            ..Pairing::default()
        },
        keys: Vec::new(),
    }
}

impl<T> Given<T> {
    pub fn has(&self, key: &str) -> bool {
        self.keys.iter().any(|k| k == key)
    }
}

impl<'de, T: serde::de::DeserializeOwned> Deserialize<'de> for Given<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let map = Mapping::deserialize(d)?;
        let keys = map.keys().map(crate::stages::params::key_text).collect();
        let value =
            serde_yaml_ng::from_value(Value::Mapping(map)).map_err(serde::de::Error::custom)?;
        Ok(Given { value, keys })
    }
}

impl<T> TypeName for Given<T> {
    fn type_name() -> String {
        "mapping".into()
    }
}

/// A model mode `p{position}.mode{r}` (as the GSA names its outputs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct ModeName {
    pub position: u32,
    pub mode: usize,
}

impl TryFrom<String> for ModeName {
    type Error = String;
    fn try_from(s: String) -> Result<Self, String> {
        let parsed = s.split_once('.').and_then(|(p, m)| {
            let position: u32 = p.strip_prefix('p')?.parse().ok()?;
            let mode: usize = m.strip_prefix("mode")?.parse().ok().filter(|&m| m >= 1)?;
            Some(ModeName { position, mode })
        });
        parsed.ok_or_else(|| {
            format!("`{s}` is not a mode name p<position>.mode<r>, e.g. exclude_modes: [p0.mode7] (the GSA output names without the quantity)")
        })
    }
}

impl From<ModeName> for String {
    fn from(m: ModeName) -> String {
        format!("p{}.mode{}", m.position, m.mode)
    }
}

impl TypeName for ModeName {
    fn type_name() -> String {
        "mode name p<position>.mode<r>".into()
    }
}

macro_rules! settings_type_name {
    ($($t:ty => $name:literal),*) => {$(
        impl TypeName for $t {
            fn type_name() -> String {
                $name.into()
            }
        }
    )*};
}
settings_type_name!(
    Weights => "mapping {mac, nfd, ndd}",
    Uncertainty => "mapping {frequency, shape, damping, from_complexity, from_estimate}",
    FrfRefinementParams => "mapping {enabled, share, regularization, max_step, samples, starts}",
    Mapping => "mapping"
);

crate::params! {
    /// The `identify` kind's params.
    pub struct Params {
        /// a model file (relative to the pipeline file), instead of the
        /// `model` input
        pub model: Option<String> = None,
        /// black_box: one optimizer over all parameters; sensitivity_guided:
        /// GSA subproblems, continuation refinement, damping least squares
        /// (needs the `sensitivity` input)
        pub strategy: StrategyName = StrategyName::BlackBox,
        /// black_box: slsqp, pso or ga
        pub optimizer: OptimizerName = OptimizerName::Slsqp,
        /// settings of the optimizer (e.g. {swarm_size: 20} for pso,
        /// {starts: 4} for slsqp)
        pub optimizer_settings: Option<Mapping> = None,
        /// maximum model evaluations, the assessment of the result included
        pub budget: usize = 2000; range Range::closed(1.0, 10_000_000.0)
            => "`budget` must be an integer in [1, 10000000]", "e.g. budget: 2000",
        /// sensitivity_guided: SLSQP runs per subproblem (default 3; 0
        /// skips the subproblem step); short for guided.repeats
        pub repeats: Option<usize> = None; range Range::closed(0.0, 1000.0),
        /// sensitivity_guided settings: {subproblem_budget: 200,
        /// subproblem_share: 0.25, spread_limit: 0.05, refine: true,
        /// restarts: 3, smoothing: 1e-3, others: random|fixed, continuation:
        /// {first: 2, step: 1, stage_tolerance: 1e-3, max_step: 0.05,
        /// secant: true}}
        pub guided: Given<GuidedParams> = Given::default(),
        /// modes of the model at its start values to leave out, e.g.
        /// [p0.mode7] (numbered as the GSA numbers them); their reference
        /// partners are not used
        pub exclude_modes: Vec<ModeName> = Vec::new(),
        /// leave out modes whose sensor amplitude is below this fraction of
        /// the median mode's (0 keeps all)
        pub observability: f64 = 0.25; range Range::at_least(0.0)
            => "`observability` must be a number ≥ 0", "e.g. observability: 0.25",
        /// compare only the frequency, not the shape, of modes whose sensor
        /// amplitude is below this fraction of the median mode's (and at
        /// least `observability`); default: `observability` (no mode by
        /// frequency alone)
        pub shape_observability: Option<f64> = None; range Range::at_least(0.0)
            => "`shape_observability` must be a number ≥ 0", "e.g. shape_observability: 0.25",
        /// weights of the criteria {mac, nfd, ndd}
        pub weights: Weights = Weights::default(),
        /// relative frequency window for pairing modes (default 0.3); short
        /// for pairing.window
        pub window: Option<f64> = None; range Range::above(0.0)
            => "`window` must be a positive fraction", "e.g. window: 0.2 for ±20 %",
        /// mode pairing (cost (1 − MAC) + NFD/frequency_scale): {window: 0.3,
        /// min_mac: 0.5, frequency_scale: 0.1, ambiguity: 0.1}
        pub pairing: Given<Pairing> = default_pairing(),
        /// standard deviations of the reference modes: {frequency: 0.002
        /// (relative), shape: 0.02 (per unit-shape component), damping: 0.1
        /// (relative), from_complexity: true (raise a mode's by its shape's
        /// complexity), from_estimate: true (raise a mode's to the spread the
        /// reference states in its uncertainty.csv, as AutoEMA writes it)}
        pub uncertainty: Uncertainty = Uncertainty::default(),
        /// largest a-priori relative standard error of a parameter the data
        /// determine
        pub max_std_error: f64 = 0.1; range Range::above(0.0)
            => "`max_std_error` must be > 0", "e.g. max_std_error: 0.1 (10 %)",
        /// relative standard deviation assumed for every parameter the update
        /// holds fixed, carried into the identified ones' intervals (consider
        /// covariance); default: uniform over each one's bounds; 0: exact
        pub fixed_spread: Option<f64> = None; range Range::at_least(0.0),
        /// identify too, and refit, the fixed parameters the score test
        /// implicates (the residual points at them)
        pub refit_implicated: bool = true,
        /// seed of the random starts (default: the pipeline's seed)
        pub seed: Option<u64> = None,
        /// reference position indices to use, e.g. [0, 2] (default all)
        pub positions: Option<Vec<u32>> = None,
        /// with the `frf` input: the last step refines the identified
        /// parameters on the measured FRFs: {enabled: true, share: 0.4
        /// (of the budget), regularization: 0.25, max_step: 0.05,
        /// samples: 128 (search over what the modes left open), starts: 7,
        /// secant: true (Broyden Jacobians between finite-difference ones)}
        pub frf_refinement: FrfRefinementParams = FrfRefinementParams::default(),
        /// with the `frf` input: the band [low, high] Hz of the FRF lines
        /// fitted (default: every line of the input)
        pub frf_band: Option<(f64, f64)> = None; range Range::at_least(0.0),
        /// with an `frf` input that carries coherence (impact or shaker
        /// test): the number of averages n behind each FRF; each line's noise
        /// then comes from its coherence, σ² = |H|²(1 − γ²)/(n γ²), which
        /// also holds noise correlated across lines (force noise under a force
        /// window) that differences of neighbouring lines miss
        pub frf_averages: Option<usize> = None; range Range::closed(1.0, 100_000.0),
        /// with the `frf` input: relative standard deviation δ of every
        /// natural frequency between the test's averages (temperature, mass
        /// loading: 1e-4 to 1e-3 on real structures); each line's noise
        /// gains δ times the FRF's sensitivity to the modes' frequencies, so
        /// a lightly damped peak narrower than a line counts as the few
        /// standard deviations a drift makes of it, not hundreds; default 0
        /// (synthesized FRFs have no drift): give it for a real test
        pub frf_drift: f64 = 0.0; range Range::closed(0.0, 0.01),
        /// with the `frf` input: the FRFs are impact-test estimates over a
        /// record of 1/Δf seconds (Δf the line spacing) with no exponential
        /// window, so a lightly damped mode that has not decayed by the
        /// record's end is measured truncated; the model's modes are then cut
        /// at the record's end too, instead of that leakage counting as
        /// misfit (up to 60σ at a 0.07 % mode); default false (shaker tests,
        /// exponential windows, synthesized FRFs without an impact test)
        pub frf_truncated: bool = false,
        /// with `frf_truncated`: time from the record's start to the hit's
        /// centre (the analyser's pre-trigger plus half the hammer pulse), s;
        /// it turns the truncation's phase away from each mode, so give it
        /// (the simulated impact test of `synthesize`: 20/2048 + 0.0015/2)
        pub frf_pre_trigger_s: f64 = 0.0; range Range::at_least(0.0),
    }
}

/// A problem with the param at `path`, with what to do about it.
pub fn problem(path: &[&str], message: impl Into<String>, help: &str) -> ParamProblem {
    ParamProblem::new(path, message, help)
}
