//! The public scene: what the observation holds beyond the ego's own state.
//! One type for every scenario: the scenario, the numbers of the ego's
//! place and the other road users' tracks, laid out as the scenario's
//! definition (`ScenarioDef`, in its own file) says. The observation module
//! renders and parses any scene through these methods and that definition
//! without knowing which scenarios exist; the scripted policies' rules read
//! it from the public side (`policy::expert`).
//!
//! In JSON a scene is one object: `scenario` (its name), then the place's
//! fields and the tracks' fields under the names the definition gives (for
//! the intersection `ego_to_conflict_m`, `other`, `follower`); its JSON
//! schema is one such object per scenario.

use super::{ScenarioKind, Track};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// The most numbers an ego's place takes.
pub const MAX_PLACE: usize = 2;
/// The most road users a scene tracks.
pub const MAX_TRACKS: usize = 3;

/// One decision's public geometry, all distances in metres: the ego's
/// place (the first number is its distance to the conflict) and a track per
/// other road user, in the scenario definition's order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scene {
    kind: ScenarioKind,
    /// The place's numbers; the slots past the scenario's count are zero.
    place: [f64; MAX_PLACE],
    /// The road users' tracks; the slots past the scenario's count are zero.
    tracks: [Track; MAX_TRACKS],
}

impl Scene {
    /// A scene of `kind` from its place numbers and tracks; `None` if the
    /// counts are not the scenario's layout.
    pub fn new(kind: ScenarioKind, place: &[f64], tracks: &[Track]) -> Option<Scene> {
        let def = kind.def();
        if place.len() != def.place_fields.len() || tracks.len() != def.track_labels.len() {
            return None;
        }
        let mut scene = Scene { kind, place: [0.0; MAX_PLACE], tracks: [Track::ZERO; MAX_TRACKS] };
        scene.place.get_mut(..place.len())?.copy_from_slice(place);
        scene.tracks.get_mut(..tracks.len())?.copy_from_slice(tracks);
        Some(scene)
    }

    /// The scenario, as the scene's layout says.
    pub fn kind(&self) -> ScenarioKind {
        self.kind
    }

    /// The ego's own distance to the conflict: the conflict zone, the
    /// crossing line or the merge point.
    pub fn ego_to_conflict_m(&self) -> f64 {
        self.place[0]
    }

    /// The numbers of the ego's place on the "You:" line, in the order of
    /// the scenario's `place_fields`.
    pub fn place(&self) -> &[f64] {
        &self.place[..self.kind.place_numbers()]
    }

    /// The ego's place as the "You:" line phrases it, from formatted numbers.
    pub(crate) fn place_text(&self, format: impl Fn(f64) -> String) -> String {
        let numbers: Vec<String> = self.place().iter().map(|x| format(*x)).collect();
        (self.kind.def().place_text)(&numbers)
    }

    /// The road users' tracks, in the order of `ScenarioKind::track_labels`.
    pub fn tracks(&self) -> &[Track] {
        &self.tracks[..self.kind.track_labels().len()]
    }

    /// The same scene with every number passed through `number` and every
    /// track through `track` (used to round to the printed precision).
    pub(crate) fn map(&self, number: impl Fn(f64) -> f64, track: impl Fn(Track) -> Track) -> Scene {
        let mut mapped = *self;
        let (places, tracks) = (self.place().len(), self.tracks().len());
        mapped.place[..places].iter_mut().for_each(|x| *x = number(*x));
        mapped.tracks[..tracks].iter_mut().for_each(|t| *t = track(*t));
        mapped
    }

    /// What a reader whose view of the other road users lags sees: this
    /// scene's own place (the ego's state is current) with the road users
    /// as `older` showed them, in the frame they were read in. Where a
    /// road user's position is relative to the ego (the merge), that is
    /// where it was beside the ego then: a driver who saw a car two metres
    /// behind it, at about its own speed, acts on "two metres behind", not
    /// on a car that has fallen back by the ego's own travel since (at
    /// 13 m/s, six metres a decision), a misreading no driver makes.
    pub(crate) fn with_road_users_of(&self, older: &Scene) -> Scene {
        if older.kind() != self.kind() {
            return *self;
        }
        Scene { tracks: older.tracks, ..*self }
    }
}

impl Serialize for Scene {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let def = self.kind.def();
        let mut map = serializer.serialize_map(Some(1 + self.place().len() + self.tracks().len()))?;
        map.serialize_entry("scenario", def.name)?;
        for (field, x) in def.place_fields.iter().zip(self.place()) {
            map.serialize_entry(field, x)?;
        }
        for (label, track) in def.track_labels.iter().zip(self.tracks()) {
            map.serialize_entry(label.field, track)?;
        }
        map.end()
    }
}

impl<'de> Deserialize<'de> for Scene {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let mut fields = serde_json::Map::deserialize(deserializer)?;
        let kind: ScenarioKind = match fields.remove("scenario") {
            Some(name) => serde_json::from_value(name).map_err(D::Error::custom)?,
            None => return Err(D::Error::missing_field("scenario")),
        };
        let def = kind.def();
        let mut take = |field: &'static str| fields.remove(field).ok_or_else(|| D::Error::missing_field(field));
        let mut place = Vec::with_capacity(def.place_fields.len());
        for field in def.place_fields {
            place.push(serde_json::from_value::<f64>(take(field)?).map_err(D::Error::custom)?);
        }
        let mut tracks = Vec::with_capacity(def.track_labels.len());
        for label in def.track_labels {
            tracks.push(serde_json::from_value::<Track>(take(label.field)?).map_err(D::Error::custom)?);
        }
        if let Some(unknown) = fields.keys().next() {
            return Err(D::Error::unknown_field(unknown, &[]));
        }
        Scene::new(kind, &place, &tracks).ok_or_else(|| D::Error::custom("a scene's parts do not fit its scenario"))
    }
}

impl schemars::JsonSchema for Scene {
    fn schema_name() -> Cow<'static, str> {
        "Scene".into()
    }

    /// One object per scenario of [`ScenarioKind::ALL`], as the derived
    /// schema of an internally tagged enum has it.
    fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
        let number = generator.subschema_for::<f64>();
        let track = generator.subschema_for::<Track>();
        let layouts: Vec<serde_json::Value> = ScenarioKind::ALL
            .iter()
            .map(|kind| {
                let def = kind.def();
                let mut properties = serde_json::Map::new();
                properties.insert("scenario".into(), serde_json::json!({"type": "string", "const": def.name}));
                let mut required = vec![serde_json::Value::from("scenario")];
                for field in def.place_fields {
                    properties.insert((*field).into(), number.clone().into());
                    required.push((*field).into());
                }
                for label in def.track_labels {
                    properties.insert(label.field.into(), track.clone().into());
                    required.push(label.field.into());
                }
                serde_json::json!({
                    "description": def.scene_doc,
                    "type": "object",
                    "properties": properties,
                    "required": required,
                })
            })
            .collect();
        schemars::json_schema!({
            "description": "Scenario-specific geometry, all distances in metres.",
            "oneOf": layouts,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::Sample;

    fn track(position_m: f64, velocity_mps: f64) -> Track {
        let s = Sample { position_m, velocity_mps };
        Track { now: s, past: [s; crate::scenario::HISTORY_LEN] }
    }

    #[test]
    fn an_older_merge_reading_is_taken_where_it_was_beside_the_ego() {
        // Half a second ago the lane car was 2 m ahead of the ego at 11 m/s;
        // the ego has since driven 6 m. A driver a decision late acts on
        // "2 m ahead, at 11 m/s", not on a car fallen 4 m behind.
        let merge = ScenarioKind::ContestedMerge;
        let then = Scene::new(merge, &[30.0, 60.0], &[track(2.0, 11.0), track(-12.0, 11.0)]).unwrap();
        let now = Scene::new(merge, &[24.0, 54.0], &[track(1.0, 12.0), track(-13.0, 12.0)]).unwrap();
        let late = now.with_road_users_of(&then);
        assert_eq!(late.place(), now.place());
        assert_eq!(late.tracks(), then.tracks());
    }

    #[test]
    fn an_older_crossing_reading_is_taken_as_it_was() {
        let crossing = ScenarioKind::YieldStandoff;
        let then = Scene::new(crossing, &[30.0], &[track(12.0, 5.0), track(20.0, 5.0)]).unwrap();
        let now = Scene::new(crossing, &[25.0], &[track(9.5, 4.0), track(17.5, 5.0)]).unwrap();
        let late = now.with_road_users_of(&then);
        assert_eq!(late.ego_to_conflict_m(), 25.0);
        assert_eq!(late.tracks(), then.tracks());
    }

    #[test]
    fn a_scene_reads_back_from_its_json_and_bad_json_is_named() {
        for kind in ScenarioKind::ALL {
            let tracks: Vec<Track> = (0..kind.track_labels().len()).map(|k| track(k as f64 - 1.5, 4.25)).collect();
            let place: Vec<f64> = (0..kind.place_numbers()).map(|k| 20.0 + k as f64).collect();
            let scene = Scene::new(kind, &place, &tracks).unwrap();
            let json = serde_json::to_value(scene).unwrap();
            assert_eq!(json["scenario"], kind.name());
            assert_eq!(serde_json::from_value::<Scene>(json.clone()).unwrap(), scene, "{kind}");
            let field = kind.def().place_fields[0];
            let mut missing = json.clone();
            missing.as_object_mut().unwrap().remove(field);
            let e = serde_json::from_value::<Scene>(missing).unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
            let mut extra = json;
            extra.as_object_mut().unwrap().insert("hidden".into(), 1.into());
            let e = serde_json::from_value::<Scene>(extra).unwrap_err().to_string();
            assert!(e.contains("hidden"), "{e}");
        }
        assert!(Scene::new(ScenarioKind::PedestrianFeint, &[1.0], &[]).is_none(), "a layout's counts are checked");
        let e = serde_json::from_str::<Scene>(r#"{"scenario": "four_way"}"#).unwrap_err().to_string();
        assert!(e.contains("unknown scenario 'four_way'"), "{e}");
    }
}
