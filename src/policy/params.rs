//! Parameter names, shapes and deterministic initialisation.
//!
//! Names follow PyTorch (`lstm.weight_ih_l0`, gates i, f, g, o; `gru.*`, gates r, z, n) so the
//! safetensors files read naturally from Python. Candle's CPU RNG cannot be seeded, so every
//! tensor is drawn from our own seeded generator, in name order.

use std::collections::BTreeMap;

use candle_core::{DType, Device, Tensor, Var};
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rand_pcg::Pcg64Mcg;

use super::config::ModelConfig;
use super::error::PolicyError;
use super::obs::CELL_CODES;
use crate::env::world::Action;

/// How a tensor is initialised.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Init {
    /// torch-ac's Linear init: N(0, 1), each row scaled to unit L2 norm.
    RowNormal,
    /// U(−b, b).
    Uniform(f32),
    /// N(0, 1) (PyTorch's `nn.Embedding`).
    Normal,
    /// All zeros.
    Zeros,
}

/// One parameter: name, shape, init.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamSpec {
    /// Stable tensor name (documented in docs/formats.md#tensor-names).
    pub name: String,
    /// Shape.
    pub shape: Vec<usize>,
    /// Initialisation.
    pub init: Init,
}

fn spec(name: &str, shape: &[usize], init: Init) -> ParamSpec {
    ParamSpec {
        name: name.to_owned(),
        shape: shape.to_vec(),
        init,
    }
}

/// Every parameter of the network described by `cfg`, sorted by name.
pub fn param_specs(cfg: &ModelConfig) -> Vec<ParamSpec> {
    let k = cfg.conv_channels;
    let (e, dk) = (cfg.word_dim, cfg.key_dim);
    let (hl, hg, hh) = (cfg.lstm_hidden, cfg.gru_hidden, cfg.head_hidden);
    let ks = cfg.conv_kernel;
    let conv_fan_in = (CELL_CODES * ks * ks) as f32;
    let lstm_b = 1.0 / (hl as f32).sqrt();
    let gru_b = 1.0 / (hg as f32).sqrt();
    let mut v = vec![
        spec(
            "encoder.conv.weight",
            &[k, CELL_CODES, ks, ks],
            Init::Uniform(1.0 / conv_fan_in.sqrt()),
        ),
        spec(
            "encoder.conv.bias",
            &[k],
            Init::Uniform(1.0 / conv_fan_in.sqrt()),
        ),
        spec("word_emb.weight", &[cfg.vocab_size, e], Init::Normal),
        spec(
            "lstm.weight_ih_l0",
            &[4 * hl, cfg.lstm_input_size()],
            Init::Uniform(lstm_b),
        ),
        spec("lstm.weight_hh_l0", &[4 * hl, hl], Init::Uniform(lstm_b)),
        spec("lstm.bias_ih_l0", &[4 * hl], Init::Uniform(lstm_b)),
        spec("lstm.bias_hh_l0", &[4 * hl], Init::Uniform(lstm_b)),
        spec("gru.weight_ih_l0", &[3 * hg, e], Init::Uniform(gru_b)),
        spec("gru.weight_hh_l0", &[3 * hg, hg], Init::Uniform(gru_b)),
        spec("gru.bias_ih_l0", &[3 * hg], Init::Uniform(gru_b)),
        spec("gru.bias_hh_l0", &[3 * hg], Init::Uniform(gru_b)),
        spec("actor.0.weight", &[hh, hl + hg], Init::RowNormal),
        spec("actor.0.bias", &[hh], Init::Zeros),
        spec("actor.2.weight", &[Action::COUNT, hh], Init::RowNormal),
        spec("actor.2.bias", &[Action::COUNT], Init::Zeros),
        spec("critic.0.weight", &[hh, hl + hg], Init::RowNormal),
        spec("critic.0.bias", &[hh], Init::Zeros),
        spec("critic.2.weight", &[1, hh], Init::RowNormal),
        spec("critic.2.bias", &[1], Init::Zeros),
    ];
    if let (true, Some(kk)) = (cfg.has_attention(), cfg.key_kernel) {
        let fan_in = (CELL_CODES * kk * kk) as f32;
        let b = 1.0 / fan_in.sqrt();
        v.push(spec(
            "encoder.key_conv.weight",
            &[k, CELL_CODES, kk, kk],
            Init::Uniform(b),
        ));
        v.push(spec("encoder.key_conv.bias", &[k], Init::Uniform(b)));
    }
    if cfg.layout_path {
        let b = 1.0 / conv_fan_in.sqrt();
        v.push(spec(
            LAYOUT_WEIGHT,
            &[k, CELL_CODES, ks, ks],
            Init::Uniform(b),
        ));
        v.push(spec(LAYOUT_BIAS, &[k], Init::Uniform(b)));
    }
    if cfg.has_attention() {
        v.push(spec("attention.q.weight", &[dk, e], Init::RowNormal));
        // With key context the keys read [Õ_key | Õ], 2K channels.
        let key_in = if cfg.key_context { 2 * k } else { k };
        v.push(spec("attention.k.weight", &[dk, key_in], Init::RowNormal));
        if cfg.search_query {
            v.push(spec("attention.search.weight", &[1, dk], Init::RowNormal));
        }
        if cfg.null_key {
            v.push(spec(NULL_KEY, &[1, dk], Init::RowNormal));
        }
    }
    v.sort_by(|a, b| a.name.cmp(&b.name));
    v
}

/// The null key's parameter ([`ModelConfig::null_key`]).
pub(crate) const NULL_KEY: &str = "attention.null.weight";

/// The layout path's encoder's parameters ([`ModelConfig::layout_path`]).
const LAYOUT_WEIGHT: &str = "layout.conv.weight";
const LAYOUT_BIAS: &str = "layout.conv.bias";

/// The LSTM's input weights, whose columns follow [`ModelConfig::lstm_input_size`].
const LSTM_W_IH: &str = "lstm.weight_ih_l0";

/// Whether parameter `name` computes the word maps (or the search map): the word
/// embeddings, the encoders that give the keys and `Õ`, and the query, key, search and
/// null-key projections. What `train --freeze-attention-at` stops training; the LSTM, the mission
/// GRU, actor and critic are the rest.
pub fn computes_maps(name: &str) -> bool {
    ["word_emb.", "encoder.", "attention."]
        .iter()
        .any(|p| name.starts_with(p))
}

/// Draws the values of one parameter.
fn draw(spec: &ParamSpec, rng: &mut Pcg64Mcg) -> Vec<f32> {
    let n: usize = spec.shape.iter().product();
    match spec.init {
        Init::Zeros => vec![0.0; n],
        Init::Uniform(b) => (0..n).map(|_| rng.random_range(-b..b)).collect(),
        Init::Normal => (0..n).map(|_| StandardNormal.sample(rng)).collect(),
        Init::RowNormal => {
            let cols = spec.shape.last().copied().unwrap_or(1).max(1);
            let mut v: Vec<f32> = (0..n).map(|_| StandardNormal.sample(rng)).collect();
            for row in v.chunks_mut(cols) {
                let norm = row.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-12);
                for x in row.iter_mut() {
                    *x /= norm;
                }
            }
            v
        }
    }
}

/// The trainable parameters, by name (sorted, so every iteration order is deterministic).
#[derive(Clone, Debug)]
pub struct Params {
    /// name → variable.
    pub vars: BTreeMap<String, Var>,
}

impl Params {
    /// Freshly initialised parameters; the same config and seed give the same values.
    pub fn init(cfg: &ModelConfig, seed: u64) -> Result<Self, PolicyError> {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut vars = BTreeMap::new();
        // The null key is drawn last, so that every other parameter starts as it does
        // without the option (a run with it differs from its twin by the option alone).
        let (mut specs, last): (Vec<_>, Vec<_>) = param_specs(cfg)
            .into_iter()
            .partition(|s| s.name != NULL_KEY);
        specs.extend(last);
        for s in specs {
            let data = draw(&s, &mut rng);
            let t = Tensor::from_vec(data, s.shape.as_slice(), &Device::Cpu)?;
            vars.insert(s.name, Var::from_tensor(&t)?);
        }
        Ok(Self { vars })
    }

    /// `self`, the parameters of `cfg`'s network, grown into those of the same network with a
    /// [`ModelConfig::layout_path`] (`train --init` of a model without one): the layout
    /// encoder drawn from `seed` as [`Self::init`] draws it, and the LSTM's input weights
    /// widened by zero columns for its features, so the grown network acts exactly as the
    /// parent until training moves them. Returns the grown config with the parameters.
    pub fn with_layout_path(
        &self,
        cfg: &ModelConfig,
        seed: u64,
    ) -> Result<(ModelConfig, Self), PolicyError> {
        if cfg.layout_path {
            return Ok((*cfg, self.clone()));
        }
        let grown = ModelConfig {
            layout_path: true,
            ..*cfg
        };
        // The layout's columns come last.
        self.grown(cfg, grown, "layout.", cfg.lstm_input_size(), seed)
    }

    /// [`Self::with_layout_path`] for the [`ModelConfig::search_query`]: the search query
    /// drawn from `seed`, and zero columns of the LSTM's input weights for the search's
    /// filtered features, which follow `F`'s (before a layout path's), so the grown network
    /// acts exactly as the parent until training moves them.
    pub fn with_search_query(
        &self,
        cfg: &ModelConfig,
        seed: u64,
    ) -> Result<(ModelConfig, Self), PolicyError> {
        if cfg.search_query {
            return Ok((*cfg, self.clone()));
        }
        let grown = ModelConfig {
            search_query: true,
            ..*cfg
        };
        self.grown(
            cfg,
            grown,
            "attention.search.",
            cfg.filter_input_size(),
            seed,
        )
    }

    /// `self` grown from `cfg` into `grown`: the parameters whose names start with `prefix`
    /// drawn from `seed`, and `grown`'s new LSTM input columns inserted as zeros at `at`.
    fn grown(
        &self,
        cfg: &ModelConfig,
        grown: ModelConfig,
        prefix: &str,
        at: usize,
        seed: u64,
    ) -> Result<(ModelConfig, Self), PolicyError> {
        grown.validate()?;
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut vars = self.vars.clone();
        for s in param_specs(&grown)
            .into_iter()
            .filter(|s| s.name.starts_with(prefix))
        {
            let t = Tensor::from_vec(draw(&s, &mut rng), s.shape.as_slice(), &Device::Cpu)?;
            vars.insert(s.name, Var::from_tensor(&t)?);
        }
        let w_ih = self
            .vars
            .get(LSTM_W_IH)
            .ok_or_else(|| PolicyError::Input(format!("missing parameter {LSTM_W_IH}")))?
            .as_tensor();
        let (rows, cols) = w_ih.dims2()?;
        let extra = grown.lstm_input_size() - cfg.lstm_input_size();
        let zeros = Tensor::zeros((rows, extra), DType::F32, &Device::Cpu)?;
        let wide = Tensor::cat(
            &[
                &w_ih.narrow(1, 0, at)?,
                &zeros,
                &w_ih.narrow(1, at, cols - at)?,
            ],
            1,
        )?;
        vars.insert(LSTM_W_IH.to_owned(), Var::from_tensor(&wide)?);
        Ok((grown, Self { vars }))
    }

    /// Parameters holding the given tensors (shapes are the caller's responsibility).
    pub fn from_tensors(tensors: BTreeMap<String, Tensor>) -> Result<Self, PolicyError> {
        let mut vars = BTreeMap::new();
        for (k, t) in tensors {
            vars.insert(k, Var::from_tensor(&t.to_dtype(DType::F32)?)?);
        }
        Ok(Self { vars })
    }

    /// Tensors that record gradients (for training).
    pub fn tracked(&self) -> BTreeMap<String, Tensor> {
        self.vars
            .iter()
            .map(|(k, v)| (k.clone(), v.as_tensor().clone()))
            .collect()
    }

    /// Tensors sharing the variables' storage that record no graph (for acting).
    pub fn detached(&self) -> BTreeMap<String, Tensor> {
        self.vars
            .iter()
            .map(|(k, v)| (k.clone(), v.as_detached_tensor()))
            .collect()
    }

    /// Number of scalar parameters.
    pub fn count(&self) -> usize {
        self.vars.values().map(|v| v.elem_count()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::policy::config::Variant;

    #[test]
    fn baseline_has_no_attention_parameters() {
        let specs = param_specs(&ModelConfig::new(Variant::Baseline));
        assert!(specs.iter().all(|s| !s.name.starts_with("attention.")));
        let att = param_specs(&ModelConfig::new(Variant::Attention));
        assert_eq!(att.len(), specs.len() + 2);
    }

    #[test]
    fn init_is_deterministic_and_row_normalised() {
        let cfg = ModelConfig::new(Variant::Attention);
        let a = Params::init(&cfg, 7).unwrap();
        let b = Params::init(&cfg, 7).unwrap();
        let c = Params::init(&cfg, 8).unwrap();
        let get = |p: &Params, n: &str| {
            p.vars[n]
                .as_tensor()
                .flatten_all()
                .unwrap()
                .to_vec1::<f32>()
                .unwrap()
        };
        assert_eq!(get(&a, "lstm.weight_ih_l0"), get(&b, "lstm.weight_ih_l0"));
        assert_ne!(get(&a, "lstm.weight_ih_l0"), get(&c, "lstm.weight_ih_l0"));
        let w = get(&a, "actor.2.weight");
        let row: f32 = w[..64].iter().map(|x| x * x).sum();
        assert!((row - 1.0).abs() < 1e-5);
    }

    #[test]
    fn the_null_key_leaves_every_other_parameter_as_drawn_without_it() {
        let plain = ModelConfig {
            key_kernel: Some(1),
            ..ModelConfig::new(Variant::Attention)
        };
        let null = ModelConfig {
            null_key: true,
            ..plain
        };
        let (a, b) = (
            Params::init(&plain, 5).unwrap(),
            Params::init(&null, 5).unwrap(),
        );
        assert_eq!(b.vars.len(), a.vars.len() + 1);
        let k0 = b.vars[NULL_KEY].as_tensor().flatten_all().unwrap();
        let norm: f32 = k0.sqr().unwrap().sum_all().unwrap().to_scalar().unwrap();
        assert!((norm - 1.0).abs() < 1e-5, "{norm}");
        for (name, v) in &a.vars {
            let bits = |t: &Tensor| t.flatten_all().unwrap().to_vec1::<f32>().unwrap();
            assert_eq!(
                bits(v.as_tensor()),
                bits(b.vars[name].as_tensor()),
                "{name}"
            );
        }
    }
}
