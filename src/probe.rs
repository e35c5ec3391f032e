//! Which probes a run adds to every answer (`--probe belief,forecast`):
//! part of a run's configuration, so a probe run is its own run directory
//! and leaderboard row, and a resume with other probes is refused. Written
//! in `run.json` as the command line spells it ("belief", "forecast",
//! "belief,forecast"; absent for none), so the runs recorded before the
//! forecast probe read back unchanged.

/// The probes of a run: each adds a field to every answer; neither changes
/// how the action is scored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Probe {
    /// `"belief"`: P(the other road user lets the ego go first).
    pub belief: bool,
    /// `"forecast"`: where the other road user will be 1 s and 2 s from
    /// now, under each intent.
    pub forecast: bool,
}

impl Probe {
    pub const NONE: Probe = Probe { belief: false, forecast: false };
    pub const BELIEF: Probe = Probe { belief: true, forecast: false };
    pub const FORECAST: Probe = Probe { belief: false, forecast: true };

    pub fn is_none(&self) -> bool {
        *self == Probe::NONE
    }
}

impl std::str::FromStr for Probe {
    type Err = String;
    /// A comma-separated list of `belief` and `forecast`, or `none`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let mut probe = Probe::NONE;
        for name in s.split(',').map(str::trim) {
            match name {
                "belief" => probe.belief = true,
                "forecast" => probe.forecast = true,
                "none" if s.trim() == "none" => {}
                other => {
                    return Err(format!(
                        "unknown probe '{other}' (expected belief, forecast, both comma-separated, or none)"
                    ));
                }
            }
        }
        Ok(probe)
    }
}

impl std::fmt::Display for Probe {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> =
            [(self.belief, "belief"), (self.forecast, "forecast")].into_iter().filter(|p| p.0).map(|p| p.1).collect();
        if names.is_empty() { f.write_str("none") } else { f.write_str(&names.join(",")) }
    }
}

impl serde::Serialize for Probe {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> serde::Deserialize<'de> for Probe {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probes_read_and_write_as_the_command_line_spells_them() {
        for (text, probe) in [
            ("none", Probe::NONE),
            ("belief", Probe::BELIEF),
            ("forecast", Probe::FORECAST),
            ("belief,forecast", Probe { belief: true, forecast: true }),
        ] {
            assert_eq!(text.parse::<Probe>(), Ok(probe));
            assert_eq!(probe.to_string(), text);
            let json = serde_json::to_string(&probe).unwrap();
            assert_eq!(json, format!("\"{text}\""));
            assert_eq!(serde_json::from_str::<Probe>(&json).unwrap(), probe);
        }
        assert_eq!("forecast, belief".parse::<Probe>(), Ok(Probe { belief: true, forecast: true }));
        assert!("belief,none".parse::<Probe>().unwrap_err().contains("unknown probe 'none'"));
        assert!("beleif".parse::<Probe>().unwrap_err().contains("unknown probe 'beleif'"));
    }
}
