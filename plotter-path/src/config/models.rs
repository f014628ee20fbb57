//! The machine models compiled into the program (`--model NAME`, `plotter models`): one table of names, the
//! firmware each speaks, a one-line description and the model's profile — the TOML of its file in `samples/`,
//! included as it is, so each figure and the source written beside it exist once.
//!
//! A profile may extend a model: a top-level `model = "axidraw-v3"` in a TOML profile takes that model's profile
//! and lays the file's own keys over it (a deep merge: tables merge key by key, every other value, arrays such as
//! `[[pens]]` included, replaces the model's). The sample profiles of the smaller variants do just that.

/// The firmware a model's controller speaks, as `--firmware` names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelFirmware {
    /// This project's firmware (plotter-fw).
    Ours,
    /// GRBL 1.1 (grblHAL, FluidNC).
    Grbl,
    /// The EiBotBoard of AxiDraw-class plotters.
    Ebb,
    /// A vintage HP-GL plotter.
    Hpgl,
}

impl ModelFirmware {
    /// The name `--firmware` takes.
    pub fn name(self) -> &'static str {
        match self {
            ModelFirmware::Ours => "ours",
            ModelFirmware::Grbl => "grbl",
            ModelFirmware::Ebb => "ebb",
            ModelFirmware::Hpgl => "hpgl",
        }
    }
}

/// One built-in machine model.
#[derive(Debug, Clone, Copy)]
pub struct Model {
    /// What `--model` takes.
    pub name: &'static str,
    /// The firmware its controller speaks.
    pub firmware: ModelFirmware,
    /// One line for people.
    pub description: &'static str,
    /// The file in `samples/` its profile is written in.
    pub sample: &'static str,
    /// The profile's TOML (the sample file's text).
    pub toml: &'static str,
}

/// The model a command uses when none is chosen.
pub const DEFAULT_MODEL: &str = "xy-kit";

/// Every built-in model, the default first.
pub const MODELS: &[Model] = &[
    Model {
        name: "xy-kit",
        firmware: ModelFirmware::Ours,
        description: "XY plotter kit: belts, lead-screw pen lift, A3 frame (the default)",
        sample: "xy-plotter.toml",
        toml: include_str!("../../../samples/xy-plotter.toml"),
    },
    Model {
        name: "servo-grbl",
        firmware: ModelFirmware::Grbl,
        description: "XY plotter kit with a hobby-servo pen lift on GRBL 1.1",
        sample: "servo-plotter.toml",
        toml: include_str!("../../../samples/servo-plotter.toml"),
    },
    Model {
        name: "axidraw-v3",
        firmware: ModelFirmware::Ebb,
        description: "AxiDraw V3 and SE/A4",
        sample: "axidraw-v3.toml",
        toml: include_str!("../../../samples/axidraw-v3.toml"),
    },
    Model {
        name: "axidraw-se-a3",
        firmware: ModelFirmware::Ebb,
        description: "AxiDraw SE/A3 and V3/A3",
        sample: "axidraw-se-a3.toml",
        toml: include_str!("../../../samples/axidraw-se-a3.toml"),
    },
    Model {
        name: "axidraw-minikit",
        firmware: ModelFirmware::Ebb,
        description: "AxiDraw MiniKit",
        sample: "axidraw-minikit.toml",
        toml: include_str!("../../../samples/axidraw-minikit.toml"),
    },
    Model {
        name: "axidraw-saxi",
        firmware: ModelFirmware::Ebb,
        description: "AxiDraw V3 with saxi's speed and acceleration limits",
        sample: "axidraw-saxi.toml",
        toml: include_str!("../../../samples/axidraw-saxi.toml"),
    },
    Model {
        name: "nextdraw-8511",
        firmware: ModelFirmware::Ebb,
        description: "Bantam Tools NextDraw 8511 with the brushless pen lift",
        sample: "nextdraw.toml",
        toml: include_str!("../../../samples/nextdraw.toml"),
    },
    Model {
        name: "idraw-h",
        firmware: ModelFirmware::Ebb,
        description: "iDraw H (A3), an EiBotBoard plotter",
        sample: "idraw-h.toml",
        toml: include_str!("../../../samples/idraw-h.toml"),
    },
    Model {
        name: "hp7475a",
        firmware: ModelFirmware::Hpgl,
        description: "HP 7475A six-pen HP-GL plotter",
        sample: "hp7475a.toml",
        toml: include_str!("../../../samples/hp7475a.toml"),
    },
    Model {
        name: "printer",
        firmware: ModelFirmware::Ours,
        description: "Cartesian 3D printer with a pen holder (and its heaters, for `plotter print`)",
        sample: "printer.toml",
        toml: include_str!("../../../samples/printer.toml"),
    },
];

/// A `model = …` key that names no model, or a chain of them that loops; `path` names the profile (or the built-in
/// model) at fault. The profile reader turns it into its own parse error.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModelError {
    /// The profile file or built-in model whose text is at fault.
    pub path: String,
    /// What is wrong.
    pub message: String,
}

/// How deep `model = …` may chain (a model extending a model …): far more than the samples use, and a loop ends.
const MAX_CHAIN: usize = 8;

impl Model {
    /// How errors name the model.
    pub fn origin(&self) -> String {
        format!("built-in model {}", self.name)
    }
}

/// The model called `name`.
pub fn find(name: &str) -> Option<&'static Model> {
    MODELS.iter().find(|m| m.name == name)
}

/// The models' names, for `--model`'s accepted values.
pub fn names() -> impl Iterator<Item = &'static str> {
    MODELS.iter().map(|m| m.name)
}

/// The models whose controller speaks `firmware`.
pub fn for_firmware(firmware: ModelFirmware) -> impl Iterator<Item = &'static Model> {
    MODELS.iter().filter(move |m| m.firmware == firmware)
}

/// The model a path probably meant: one whose name or sample file is the path's file name (`axidraw-v3`,
/// `samples/nextdraw.toml`).
pub fn meant_by_path(path: &std::path::Path) -> Option<&'static Model> {
    let file = path.file_name()?.to_str()?;
    let stem = file.strip_suffix(".toml").unwrap_or(file);
    MODELS.iter().find(|m| m.name == stem || m.sample == file)
}

/// The model name closest to `name`, for a "did you mean": the first that begins with it, else the nearest with at
/// most a third of its letters off (case aside).
pub fn closest(name: &str) -> Option<&'static str> {
    let name = name.to_lowercase();
    if name.len() >= 3
        && let Some(m) = names().find(|n| n.starts_with(&name))
    {
        return Some(m);
    }
    let limit = name.chars().count().div_ceil(3).max(2);
    names().map(|n| (edit_distance(&name, n), n)).filter(|&(d, _)| d <= limit).min_by_key(|&(d, _)| d).map(|(_, n)| n)
}

/// What to say about a model name that is not built in: the closest name, and every name.
pub fn unknown(name: &str) -> String {
    let all = names().collect::<Vec<_>>().join(", ");
    match closest(name) {
        Some(c) => format!("no built-in machine model {name:?}; did you mean {c:?}? (models: {all})"),
        None => format!("no built-in machine model {name:?} (models: {all})"),
    }
}

/// Levenshtein distance, by characters: how many insertions, deletions and substitutions turn `a` into `b`.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let above = row[j + 1];
            row[j + 1] = (diagonal + usize::from(ca != cb)).min(above + 1).min(row[j] + 1);
            diagonal = above;
        }
    }
    row[b.len()]
}

/// Lay `over` onto `base`: tables merge key by key (recursively), any other value of `over` replaces `base`'s.
pub fn merge(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// `table` with its `model = "…"` key (if any) replaced by that model's keys underneath it, as far as the chain
/// goes; `origin` names the profile in errors.
pub(crate) fn expand(mut table: toml::Table, origin: &str) -> Result<toml::Table, ModelError> {
    let mut chain: Vec<&str> = Vec::new();
    let mut layers = Vec::new();
    while let Some(value) = table.remove("model") {
        let bad = |message: String| ModelError { path: origin.to_string(), message };
        let Some(name) = value.as_str() else {
            return Err(bad(format!("model: must be the name of a built-in model in quotes, not {value}")));
        };
        let model = find(name).ok_or_else(|| bad(format!("model: {}", unknown(name))))?;
        if chain.contains(&model.name) || chain.len() >= MAX_CHAIN {
            return Err(bad(format!("model: the models extend each other in a loop ({})", chain.join(" → "))));
        }
        chain.push(model.name);
        let base: toml::Table =
            toml::from_str(model.toml).map_err(|e| ModelError { path: model.origin(), message: e.to_string() })?;
        layers.push(std::mem::replace(&mut table, base));
    }
    // `table` is now the innermost model; lay each extension over it, the file's own keys last.
    for layer in layers.into_iter().rev() {
        merge(&mut table, layer);
    }
    Ok(table)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::profile::{MachineProfile, extend_model as extend};

    #[test]
    fn every_model_loads_within_the_physical_ranges() {
        // The profile is validated where it is read: each model passes the same ranges a file does.
        for m in MODELS {
            let p = MachineProfile::from_toml(m.toml, &m.origin()).unwrap_or_else(|e| panic!("{}: {e}", m.name));
            assert_eq!(p.ebb.is_some(), m.firmware == ModelFirmware::Ebb, "{}", m.name);
        }
        assert_eq!(MODELS[0].name, DEFAULT_MODEL);
        assert_eq!(find(DEFAULT_MODEL).unwrap().profile(), MachineProfile::default_plotter());
    }

    #[test]
    fn every_sample_profile_is_a_model() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples");
        let mut files: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.unwrap().file_name().into_string().ok())
            .filter(|f| f.ends_with(".toml"))
            .collect();
        files.sort();
        let mut samples: Vec<String> = MODELS.iter().map(|m| m.sample.to_string()).collect();
        samples.sort();
        assert_eq!(files, samples);
    }

    #[test]
    fn the_variants_take_the_v3_figures_and_change_only_their_own() {
        let v3 = find("axidraw-v3").unwrap().profile();
        let a3 = find("axidraw-se-a3").unwrap().profile();
        // From the AxiDraw software's x_travel_V3A3 / y_travel_V3A3 (16.93 × 11.69 in).
        assert_eq!((a3.axes.x.travel_mm, a3.axes.y.travel_mm), (430.0, 297.0));
        assert_eq!((a3.axes.x.steps_per_mm, a3.pen.settle_ms, a3.ebb), (80.0, 126.0, v3.ebb));
        let mini = find("axidraw-minikit").unwrap().profile();
        // 6.30 × 4.00 in.
        assert_eq!(
            (mini.axes.x.travel_mm, mini.axes.y.travel_mm, mini.name.as_str()),
            (160.0, 101.6, "AxiDraw MiniKit")
        );
        let nd = find("nextdraw-8511").unwrap().profile();
        let e = nd.ebb.unwrap();
        assert_eq!((e.pen_pin, e.pen_up_position, e.pen_down_position, e.step_mode), (2, 9720, 7560, 1));
        assert_eq!((nd.pen.settle_ms, nd.axes.x.travel_mm), (50.0, 300.0));
        let servo = find("servo-grbl").unwrap().profile();
        let kit = MachineProfile::default_plotter();
        assert!(servo.pen.uses_servo() && !kit.pen.uses_servo());
        assert_eq!((servo.pens.len(), servo.axes.x), (3, kit.axes.x), "the kit's pens and axes");
        let hp = find("hp7475a").unwrap().profile();
        // 16158 × 11040 plotter units of 0.025 mm.
        assert_eq!((hp.axes.x.travel_mm, hp.axes.y.travel_mm, hp.link.baud), (403.95, 276.0, 9600));
    }

    #[test]
    fn merge_is_deep_for_tables_and_replaces_everything_else() {
        let mut base: toml::Table = toml::from_str("a = 1\n[t]\nx = 1\ny = 2\n[[p]]\nn = 1\n[[p]]\nn = 2\n").unwrap();
        let over: toml::Table = toml::from_str("a = 5\n[t]\ny = 3\nz = 4\n[[p]]\nn = 9\n").unwrap();
        merge(&mut base, over);
        let want: toml::Table = toml::from_str("a = 5\n[t]\nx = 1\ny = 3\nz = 4\n[[p]]\nn = 9\n").unwrap();
        assert_eq!(base, want);
    }

    #[test]
    fn a_profile_extends_a_model_and_bad_names_are_told() {
        let p =
            MachineProfile::from_toml("model = \"axidraw-v3\"\n[pen]\ndraw_feed_mm_s = 40.0\n", "mine.toml").unwrap();
        assert_eq!((p.pen.draw_feed_mm_s, p.pen.travel_feed_mm_s, p.axes.x.travel_mm), (40.0, 165.0, 300.0));
        let err = MachineProfile::from_toml("model = \"axidraw-v9\"\n", "mine.toml").unwrap_err().to_string();
        assert!(
            err.starts_with("invalid machine profile mine.toml: model: no built-in machine model \"axidraw-v9\"; did you mean \"axidraw-v3\"? (models: xy-kit, servo-grbl, axidraw-v3,"),
            "{err}"
        );
        let err = MachineProfile::from_toml("model = 3\n", "mine.toml").unwrap_err().to_string();
        assert!(err.contains("model: must be the name of a built-in model"), "{err}");
        // The file's keys still go through the ranges, named with the file.
        let err = MachineProfile::from_toml("model = \"xy-kit\"\n[pen]\ndraw_feed_mm_s = 0.0\n", "m.toml").unwrap_err();
        assert!(err.to_string().contains("m.toml: pen.draw_feed_mm_s: 0 is outside the accepted range"), "{err}");
    }

    #[test]
    fn extending_a_model_from_the_command_line() {
        let v3 = find("axidraw-v3").unwrap();
        let p = extend(v3, "[axes.x]\ntravel_mm = 250.0\n", "small.toml").unwrap();
        assert_eq!((p.axes.x.travel_mm, p.axes.y.travel_mm, p.ebb.unwrap().pen_up_position), (250.0, 218.0, 20641));
        let same = extend(v3, "model = \"axidraw-v3\"\n", "same.toml").unwrap();
        assert_eq!(same, v3.profile());
        let err = extend(v3, "model = \"xy-kit\"\n", "other.toml").unwrap_err().to_string();
        assert!(err.contains("the file extends \"xy-kit\" but --model says \"axidraw-v3\""), "{err}");
    }

    #[test]
    fn names_close_to_a_model_are_suggested() {
        assert_eq!(closest("axidraw-v4"), Some("axidraw-v3"));
        assert_eq!(closest("nextdraw"), Some("nextdraw-8511"));
        assert_eq!(closest("AxiDraw-SE-A3"), Some("axidraw-se-a3"));
        assert_eq!(closest("axi"), Some("axidraw-v3"), "the first model the name begins");
        assert_eq!(closest("zzzzzzzzzz"), None);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(meant_by_path(std::path::Path::new("samples/nextdraw.toml")).map(|m| m.name), Some("nextdraw-8511"));
        assert_eq!(meant_by_path(std::path::Path::new("axidraw-v3")).map(|m| m.name), Some("axidraw-v3"));
        assert!(meant_by_path(std::path::Path::new("mine.toml")).is_none());
    }
}
