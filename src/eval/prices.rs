//! Token prices (`configs/prices.toml`) and what a run costs.
//!
//! The built-in table is compiled in, like the endpoints file; a user file
//! (`--prices-file`) of the same shape is laid over it model by model. A
//! price is found by the host of the endpoint's base URL (which provider
//! bills) and the model id; a model with no price has cost "unknown" (never
//! 0), and servers on this machine are free.
//!
//! Costs are estimates: see the file's header for what it leaves out.

use crate::rundir::Pricing;
use std::collections::BTreeMap;

/// The prices shipped with the binary (a copy of `configs/prices.toml`).
pub const BUILTIN_PRICES: &str = include_str!("../../configs/prices.toml");

/// Largest price accepted, USD per million tokens: guards against a price
/// typed per token or in cents turning every estimate absurd.
const MAX_PRICE: f64 = 10_000.0;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PriceError {
    #[error("{path}: {message}")]
    Parse { path: String, message: String },
    #[error("{path}: {field}: {message}")]
    Field { path: String, field: String, message: String },
}

/// USD per million tokens for one model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rates {
    pub input: f64,
    /// Prompt tokens served from the provider's cache; the input price when
    /// the provider gives no discount.
    pub cached_input: Option<f64>,
    pub output: f64,
}

impl Rates {
    pub const FREE: Rates = Rates { input: 0.0, cached_input: Some(0.0), output: 0.0 };

    pub fn cached(&self) -> f64 {
        self.cached_input.unwrap_or(self.input)
    }
}

/// One `[providers.NAME]` table as written.
#[derive(Debug, Clone, Default, PartialEq)]
struct ProviderEntry {
    hosts: Vec<String>,
    source: Option<String>,
    free: bool,
    models: BTreeMap<String, Rates>,
    images: BTreeMap<String, crate::rundir::ImageTokenRule>,
}

/// A prices file as written, every field checked (see [`read_file`]).
#[derive(Debug, Clone)]
struct PricesFileRaw {
    as_of: String,
    providers: BTreeMap<String, ProviderEntry>,
}

/// Read a prices file field by field (rather than through serde), so that
/// any error names the exact field: `providers.openai.models."gpt-4o".input`.
fn read_file(path: &str, text: &str) -> Result<PricesFileRaw, PriceError> {
    use toml::Value;
    let table: toml::Table =
        toml::from_str(text).map_err(|e| PriceError::Parse { path: path.to_string(), message: one_line(&e, text) })?;
    let err = |field: &str, message: &str| PriceError::Field {
        path: path.to_string(),
        field: field.to_string(),
        message: message.to_string(),
    };
    let unknown = |t: &toml::Table, at: &str, known: &[&str]| -> Result<(), PriceError> {
        match t.keys().find(|k| !known.contains(&k.as_str())) {
            Some(k) => Err(err(&format!("{at}{k}"), &format!("unknown field (expected one of: {})", known.join(", ")))),
            None => Ok(()),
        }
    };
    let number = |v: &Value, at: &str| -> Result<f64, PriceError> {
        let x = match v {
            Value::Float(x) => *x,
            Value::Integer(n) => *n as f64,
            _ => return Err(err(at, &format!("expected USD per million tokens, got {v}"))),
        };
        if x.is_finite() && (0.0..=MAX_PRICE).contains(&x) {
            Ok(x)
        } else {
            Err(err(at, &format!("expected USD per million tokens from 0 to {MAX_PRICE}, got {x}")))
        }
    };
    unknown(&table, "", &["as_of", "providers"])?;
    let as_of = match table.get("as_of") {
        Some(Value::String(s)) if is_date(s) => s.clone(),
        Some(v) => return Err(err("as_of", &format!("expected a date YYYY-MM-DD, got {v}"))),
        None => return Err(err("as_of", "missing: the date the prices were read (YYYY-MM-DD)")),
    };
    let mut providers = BTreeMap::new();
    let empty = toml::Table::new();
    let provider_tables = match table.get("providers") {
        Some(Value::Table(t)) => t,
        Some(_) => return Err(err("providers", "expected a table of providers")),
        None => &empty,
    };
    for (name, v) in provider_tables {
        let at = format!("providers.{name}");
        let Value::Table(t) = v else { return Err(err(&at, "expected a table")) };
        unknown(t, &format!("{at}."), &["hosts", "source", "free", "models", "images"])?;
        let mut entry = ProviderEntry::default();
        match t.get("hosts") {
            Some(Value::Array(hosts)) => {
                for h in hosts {
                    let Value::String(h) = h else { return Err(err(&format!("{at}.hosts"), "expected host names")) };
                    entry.hosts.push(h.trim().to_ascii_lowercase());
                }
            }
            Some(_) => return Err(err(&format!("{at}.hosts"), "expected a list of host names")),
            None => {}
        }
        match t.get("source") {
            Some(Value::String(s)) => entry.source = Some(s.clone()),
            Some(_) => return Err(err(&format!("{at}.source"), "expected a string")),
            None => {}
        }
        match t.get("free") {
            Some(Value::Boolean(b)) => entry.free = *b,
            Some(_) => return Err(err(&format!("{at}.free"), "expected true or false")),
            None => {}
        }
        let models = match t.get("models") {
            Some(Value::Table(m)) => m,
            Some(_) => return Err(err(&format!("{at}.models"), "expected a table of model prices")),
            None => &empty,
        };
        for (model, v) in models {
            let at = format!("{at}.models.\"{model}\"");
            let Value::Table(r) = v else {
                return Err(err(&at, "expected { input = ..., cached_input = ..., output = ... }"));
            };
            unknown(r, &format!("{at}."), &["input", "cached_input", "output"])?;
            let required = |k: &str| match r.get(k) {
                Some(v) => number(v, &format!("{at}.{k}")),
                None => Err(err(&format!("{at}.{k}"), "missing (USD per million tokens)")),
            };
            let cached_input = r.get("cached_input").map(|v| number(v, &format!("{at}.cached_input"))).transpose()?;
            entry
                .models
                .insert(model.clone(), Rates { input: required("input")?, cached_input, output: required("output")? });
        }
        match t.get("images") {
            Some(Value::Table(rules)) => {
                for (model, v) in rules {
                    let at = format!("{at}.images.\"{model}\"");
                    let rule = v.clone().try_into::<crate::rundir::ImageTokenRule>().map_err(|e| {
                        err(&at, &format!("{} (expected e.g. {{ rule = \"tiles\", base = 85, per_tile = 170, low = 85 }}, {{ rule = \"patches\", multiplier = 1.62 }}, {{ rule = \"area\", px_per_token = 750 }} or {{ rule = \"per_image\", tokens = 258 }})", e.message().trim()))
                    })?;
                    entry.images.insert(model.clone(), rule);
                }
            }
            Some(_) => return Err(err(&format!("{at}.images"), "expected a table of image-token rules by model")),
            None => {}
        }
        providers.insert(name.clone(), entry);
    }
    Ok(PricesFileRaw { as_of, providers })
}

/// One provider after merging: its prices, each dated by the file it came
/// from.
#[derive(Debug, Clone, Default, PartialEq)]
struct Provider {
    hosts: Vec<String>,
    source: Option<String>,
    free: bool,
    /// Set by the file that made the provider free.
    free_as_of: String,
    models: BTreeMap<String, (Rates, String)>,
    images: BTreeMap<String, crate::rundir::ImageTokenRule>,
}

/// The price table in force: built-in, then any user file over it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Prices {
    providers: BTreeMap<String, Provider>,
}

impl Prices {
    pub fn builtin() -> Prices {
        Prices::parse("configs/prices.toml (built in)", BUILTIN_PRICES).expect("the built-in prices file parses")
    }

    /// Parse one prices file into a table of its own.
    pub fn parse(path: &str, text: &str) -> Result<Prices, PriceError> {
        let mut prices = Prices::default();
        prices.overlay(path, text)?;
        Ok(prices)
    }

    /// Lay the file `text` over this table: its models replace or add
    /// prices, its hosts and source replace a provider's when given.
    pub fn overlay(&mut self, path: &str, text: &str) -> Result<(), PriceError> {
        let raw = read_file(path, text)?;
        let field = |field: String, message: String| PriceError::Field { path: path.to_string(), field, message };
        for (name, entry) in raw.providers {
            let known = self.providers.contains_key(&name);
            if !known && entry.hosts.is_empty() {
                return Err(field(
                    format!("providers.{name}.hosts"),
                    "a new provider needs the hosts of its base URL (e.g. [\"api.example.com\"])".into(),
                ));
            }
            let p = self.providers.entry(name).or_default();
            if !entry.hosts.is_empty() {
                p.hosts = entry.hosts;
            }
            if entry.source.is_some() {
                p.source = entry.source;
            }
            if entry.free {
                p.free = true;
                p.free_as_of = raw.as_of.clone();
            }
            for (model, rates) in entry.models {
                p.models.insert(model, (rates, raw.as_of.clone()));
            }
            p.images.extend(entry.images);
        }
        Ok(())
    }

    /// The price of `model` served from `base_url`, or `None` when the
    /// table has none (the cost is then unknown).
    pub fn lookup(&self, base_url: &str, model: &str) -> Option<Pricing> {
        let host = reqwest::Url::parse(base_url).ok()?.host_str()?.to_ascii_lowercase();
        let (name, provider) = self.providers.iter().find(|(_, p)| p.hosts.contains(&host))?;
        let pricing = |entry: &str, rates: Rates, as_of: &str| Pricing {
            provider: name.clone(),
            entry: entry.to_string(),
            input: rates.input,
            cached_input: rates.cached(),
            output: rates.output,
            as_of: as_of.to_string(),
            source: provider.source.clone(),
            image_tokens: by_model(&provider.images, model).map(|(_, rule)| *rule),
        };
        if let Some((entry, (rates, as_of))) = by_model(&provider.models, model) {
            return Some(pricing(entry, *rates, as_of));
        }
        provider.free.then(|| pricing("*", Rates::FREE, &provider.free_as_of))
    }
}

/// The entry of `model` in a table keyed by model id or `*` pattern: the
/// exact id, else the longest matching pattern.
fn by_model<'a, T>(table: &'a BTreeMap<String, T>, model: &str) -> Option<(&'a String, &'a T)> {
    table.get_key_value(model).or_else(|| {
        table
            .iter()
            .filter(|(pattern, _)| pattern.contains('*') && crate::llm::profile::glob_match(pattern, model))
            .max_by_key(|(pattern, _)| pattern.len())
    })
}

/// A TOML syntax error on one line (its message spans several, with a
/// caret), with the line it is on.
fn one_line(e: &toml::de::Error, text: &str) -> String {
    let msg = e.message().trim().to_string();
    match e.span() {
        Some(span) => format!("line {}: {msg}", text[..span.start.min(text.len())].matches('\n').count() + 1),
        None => msg,
    }
}

fn is_date(s: &str) -> bool {
    let b = s.as_bytes();
    b.len() == 10 && b.iter().enumerate().all(|(i, c)| if i == 4 || i == 7 { *c == b'-' } else { c.is_ascii_digit() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_shipped_endpoint_model_and_alias_has_a_price() {
        let prices = Prices::builtin();
        let endpoints = crate::eval::config::EndpointsFile::builtin();
        // The paper's six models, by alias, on their endpoint.
        for (alias, m) in &endpoints.models {
            let url = &endpoints.endpoints[&m.endpoint].base_url;
            assert!(prices.lookup(url, &m.id).is_some(), "alias {alias}: {} at {url}", m.id);
        }
        // Local endpoints are free, whatever the model.
        for name in ["vllm", "ollama", "local"] {
            let p = prices.lookup(&endpoints.endpoints[name].base_url, "any/model").unwrap();
            assert_eq!((p.provider.as_str(), p.input, p.cached_input, p.output), ("local", 0.0, 0.0, 0.0), "{name}");
        }
        let at = |endpoint: &str, model: &str| prices.lookup(&endpoints.endpoints[endpoint].base_url, model);
        for (endpoint, model) in [
            ("openai", "gpt-4o"),
            ("openai", "gpt-4.1"),
            ("openai", "gpt-5"),
            ("openai", "gpt-5-mini"),
            ("openai", "o3"),
            ("openai", "o4-mini"),
            ("anthropic", "claude-sonnet-4-5"),
            ("gemini", "gemini-2.5-flash"),
            ("deepseek", "deepseek-reasoner"),
            ("together", "deepseek-ai/DeepSeek-R1"),
            ("openrouter", "openai/gpt-5"),
        ] {
            let p = at(endpoint, model).unwrap_or_else(|| panic!("{endpoint} {model}"));
            assert!(p.input > 0.0 && p.output >= p.input * 0.5, "{endpoint} {model}: {p:?}");
            assert!(p.cached_input <= p.input, "{endpoint} {model}");
        }
        assert!(at("openai", "gpt-7-imaginary").is_none(), "an unknown model has no price, never 0");
        assert!(prices.lookup("https://llm.example.org/v1", "gpt-4o").is_none(), "an unknown host has no price");
    }

    #[test]
    fn exact_ids_beat_patterns_and_longer_patterns_beat_shorter() {
        let text = r#"
as_of = "2025-01-02"
[providers.x]
hosts = ["api.x.com"]
[providers.x.models]
"m" = { input = 1.0, output = 2.0 }
"m*" = { input = 3.0, output = 4.0 }
"m-mini*" = { input = 5.0, output = 6.0 }
"#;
        let p = Prices::parse("f.toml", text).unwrap();
        let input = |model: &str| p.lookup("https://API.x.com/v1", model).map(|p| (p.entry, p.input));
        assert_eq!(input("m"), Some(("m".into(), 1.0)));
        assert_eq!(input("m-2025"), Some(("m*".into(), 3.0)));
        assert_eq!(input("m-mini-2025"), Some(("m-mini*".into(), 5.0)));
        assert_eq!(input("other"), None);
    }

    #[test]
    fn cached_tokens_are_billed_at_the_cached_price_and_reasoning_as_output() {
        let priced = |input: f64, cached_input: Option<f64>, output: f64| {
            let mut p = Prices::parse(
                "f.toml",
                "as_of = \"2025-01-01\"\n[providers.x]\nhosts = [\"h.example\"]\n[providers.x.models]\n\"m\" = { input = 1.0, output = 1.0 }\n",
            )
            .unwrap();
            p.providers
                .get_mut("x")
                .unwrap()
                .models
                .insert("m".into(), (Rates { input, cached_input, output }, "2025-01-01".into()));
            p.lookup("https://h.example/v1", "m").unwrap()
        };
        let r = priced(2.0, Some(0.5), 8.0);
        // 1000 prompt (400 cached), 300 output of which any part is reasoning.
        let cost = r.cost(1000, 400, 300);
        assert!((cost - (600.0 * 2.0 + 400.0 * 0.5 + 300.0 * 8.0) / 1e6).abs() < 1e-15, "{cost}");
        // No discount listed: cached tokens cost the input price.
        let flat = priced(2.0, None, 8.0);
        assert_eq!(flat.cost(1000, 400, 0), 1000.0 * 2.0 / 1e6);
        // A provider reporting more cached than prompt tokens is clamped.
        assert_eq!(r.cost(100, 500, 0), 100.0 * 0.5 / 1e6);
    }

    /// The providers' documented counts for one 512 x 512 picture: OpenAI's
    /// 85 (low) and 255 (high, one tile), Anthropic's 512 x 512 / 750,
    /// Gemini 2.x's 258; and OpenAI's own 1024 x 1024 example, 765.
    #[test]
    fn the_image_rules_give_the_providers_documented_counts() {
        use crate::rundir::ImageDetail::{Auto, High, Low};
        let prices = Prices::builtin();
        let rule = |url: &str, model: &str| prices.lookup(url, model).unwrap().image_tokens.unwrap();
        let gpt4o = rule("https://api.openai.com/v1", "gpt-4o");
        assert_eq!(
            [gpt4o.tokens(512, 512, Low), gpt4o.tokens(512, 512, High), gpt4o.tokens(512, 512, Auto)],
            [85, 255, 255]
        );
        assert_eq!(gpt4o.tokens(1024, 1024, High), 765);
        assert_eq!(gpt4o.tokens(2048, 4096, High), 1105);
        assert_eq!(rule("https://api.openai.com/v1", "gpt-4o-mini").tokens(512, 512, High), 2833 + 5667);
        assert_eq!(rule("https://api.openai.com/v1", "gpt-4.1-mini").tokens(512, 512, High), 415);
        assert_eq!(rule("https://api.anthropic.com/v1/", "claude-sonnet-4-5").tokens(512, 512, Auto), 350);
        assert_eq!(
            rule("https://generativelanguage.googleapis.com/v1beta/openai/", "gemini-2.5-flash").tokens(512, 512, Low),
            258
        );
        assert_eq!(rule("https://openrouter.ai/api/v1", "google/gemini-2.5-flash").tokens(512, 512, High), 258);
        // A local server has no rule: its pictures cost nothing, and their
        // tokens are counted by the fallback.
        assert_eq!(prices.lookup("http://127.0.0.1:8000/v1", "m").unwrap().image_tokens, None);
        let bad = "as_of = \"2025-01-01\"\n[providers.openai.images]\n\"*\" = { rule = \"tiles\", base = 85 }\n";
        let err = Prices::builtin().overlay("f.toml", bad).unwrap_err().to_string();
        assert!(err.starts_with("f.toml: providers.openai.images.\"*\": ") && err.contains("per_tile"), "{err}");
    }

    #[test]
    fn a_user_file_overrides_and_adds_dated_by_itself() {
        let mut p = Prices::builtin();
        let builtin_date = p.lookup("https://api.openai.com/v1", "gpt-4o").unwrap().as_of;
        p.overlay(
            "mine.toml",
            r#"
as_of = "2030-05-06"
[providers.openai.models]
"gpt-4o" = { input = 1.0, output = 2.0 }
[providers.lab]
hosts = ["gpu.lab.internal"]
free = true
"#,
        )
        .unwrap();
        let o = p.lookup("https://api.openai.com/v1", "gpt-4o").unwrap();
        assert_eq!((o.input, o.cached_input, o.as_of.as_str()), (1.0, 1.0, "2030-05-06"));
        let mini = p.lookup("https://api.openai.com/v1", "gpt-4o-mini").unwrap();
        assert_eq!(mini.as_of, builtin_date, "untouched prices keep the built-in date");
        let lab = p.lookup("http://gpu.lab.internal:8000/v1", "llama").unwrap();
        assert_eq!((lab.input, lab.cached_input, lab.output, lab.entry.as_str()), (0.0, 0.0, 0.0, "*"));
    }

    #[test]
    fn malformed_files_name_the_field() {
        let err = |text: &str| Prices::parse("p.toml", text).unwrap_err().to_string();
        let e = err(
            "as_of = \"2025-01-01\"\n[providers.openai]\nhosts=[\"h\"]\n[providers.openai.models]\n\"gpt-4o\" = { input = -1.0, output = 2.0 }\n",
        );
        assert_eq!(
            e,
            "p.toml: providers.openai.models.\"gpt-4o\".input: expected USD per million tokens from 0 to 10000, got -1"
        );
        let e = err(
            "as_of = \"2025-01-01\"\n[providers.openai]\nhosts=[\"h\"]\n[providers.openai.models]\n\"m\" = { input = 1.0, output = 2.0, cached_input = 1e9 }\n",
        );
        assert!(e.contains("providers.openai.models.\"m\".cached_input: expected USD"), "{e}");
        let e = err("as_of = \"last year\"\n");
        assert_eq!(e, "p.toml: as_of: expected a date YYYY-MM-DD, got \"last year\"");
        let e = err("[providers.a]\nhosts=[\"h\"]\n");
        assert_eq!(e, "p.toml: as_of: missing: the date the prices were read (YYYY-MM-DD)");
        let e = err("as_of = \"2025-01-01\"\n[providers.a.models]\n\"m\" = { input = 1.0, outptu = 2.0 }\n");
        assert_eq!(
            e,
            "p.toml: providers.a.models.\"m\".outptu: unknown field (expected one of: input, cached_input, output)"
        );
        let e = err("as_of = \"2025-01-01\"\n[providers.a.models]\n\"m\" = { input = \"cheap\", output = 2.0 }\n");
        assert_eq!(e, "p.toml: providers.a.models.\"m\".input: expected USD per million tokens, got \"cheap\"");
        let e = err("as_of = \"2025-01-01\"\n[providers.a.models]\n\"m\" = { input = 1 }\n");
        assert_eq!(e, "p.toml: providers.a.models.\"m\".output: missing (USD per million tokens)");
        let e = err("as_of = \"2025-01-01\"\n\n[providers.a\n");
        assert!(e.starts_with("p.toml: line 3: "), "{e}");
        assert!(!e.contains('\n'), "one line: {e}");
        let e = err("as_of = \"2025-01-01\"\n[providers.new.models]\n\"m\" = { input = 1.0, output = 2.0 }\n");
        assert!(e.starts_with("p.toml: providers.new.hosts: a new provider needs"), "{e}");
    }
}
