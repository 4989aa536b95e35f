//! The settings' tests: presets, sections, keys and their errors.

use super::*;
use crate::named::Named;

/// Every preset the list names (the demo's `O` key cycles it, `smooth` last) exists and validates; an unknown
/// name lists them all.
#[test]
fn every_listed_preset_exists() {
    for name in PRESETS {
        let mut s = Settings::preset(name).unwrap();
        s.radius = 0.01;
        s.validate().unwrap();
    }
    assert_eq!(PRESETS.last(), Some(&"smooth"));
    let e = Settings::preset("nope").unwrap_err().to_string();
    assert!(PRESETS.iter().all(|p| e.contains(p)), "{e}");
}

/// Every enum name parses back to its variant, in TOML and through `FromStr`; a bad name lists the good ones.
#[test]
fn enum_names_round_trip() {
    fn check<T: Named + std::fmt::Debug + PartialEq + std::str::FromStr<Err = Error> + Serialize>() {
        for (&v, &n) in T::ALL.iter().zip(T::NAMES) {
            assert_eq!(v.name(), n);
            assert_eq!(n.parse::<T>().unwrap(), v);
            assert_eq!(serde_json::to_string(&v).unwrap(), format!("{n:?}"));
        }
        let e = "nope".parse::<T>().unwrap_err().to_string();
        assert!(e.contains("nope") && e.contains(T::NAMES[0]), "{e}");
    }
    check::<Filter>();
    check::<Surface>();
    check::<Kernel>();
    check::<SplatMode>();
    let s: Settings = toml::from_str("[filter]\nfilter = \"curvature-flow\"\n[splat]\nmode = \"quad-min\"").unwrap();
    assert_eq!((s.filter.method, s.splat.mode), (Filter::CurvatureFlow, SplatMode::QuadMin));
}

/// Every key of every section is checked: set alone far outside any range (±1e30 for a real number or a
/// component, u32::MAX for a count, 1e30 for an optional value), the sections' check names that section and
/// key; the list of sections covers every table of the settings. In a file, the error is the key's byte
/// offset (a subsection's key under its own header).
#[test]
fn every_key_of_every_section_is_checked() {
    use serde_json::{json, Value};
    let base = Settings::default().with(|s| s.radius = 0.01);
    base.validate().unwrap();
    let all = serde_json::to_value(&base).unwrap();
    let tables: Vec<&str> =
        all.as_object().unwrap().iter().filter(|(_, v)| v.is_object()).map(|(k, _)| k.as_str()).collect();
    let mut names: Vec<&str> = base.sections().iter().map(|s| s.name()).collect();
    names.sort();
    assert_eq!(names, tables, "one section per table of the settings");
    // (section, dotted key inside it, the leaf's path, its bad values).
    fn leaves(at: &[String], v: &Value, out: &mut Vec<(Vec<String>, Vec<Value>)>) {
        match v {
            Value::Object(o) => o.iter().for_each(|(k, x)| leaves(&[at, std::slice::from_ref(k)].concat(), x, out)),
            Value::Number(n) if n.is_u64() => out.push((at.to_vec(), vec![json!(u32::MAX)])),
            Value::Number(_) | Value::Null => out.push((at.to_vec(), vec![json!(1e30), json!(-1e30)])),
            Value::Array(a) if a.iter().all(|c| c.is_f64()) => {
                let with = |x: f64| Value::Array([vec![json!(x)], a[1..].to_vec()].concat());
                out.push((at.to_vec(), vec![with(1e30), with(-1e30)]))
            }
            _ => {}
        }
    }
    let mut checked = 0;
    for section in &tables {
        let mut found = vec![];
        leaves(&[], &all[section], &mut found);
        for (path, bads) in found {
            let key = path.join(".");
            for bad in bads {
                let mut j = all.clone();
                let slot = path.iter().fold(&mut j[section], |v, k| &mut v[k]);
                *slot = bad.clone();
                let s: Settings = serde_json::from_value(j).unwrap_or_else(|e| panic!("{section}.{key} = {bad}: {e}"));
                let (sec, k, reason) = s.check_sections().expect_err(&format!("{section}.{key} = {bad} passes"));
                assert_eq!((sec, k), (*section, key.as_str()), "{section}.{key} = {bad}: {reason}");
                checked += 1;
            }
        }
    }
    assert!(checked > 150, "{checked} values checked");
    let dir = std::env::temp_dir().join(format!("meniscus-sections-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (text, key) in [
        ("[ssr]\nrefine = 2\nstride = 0.0\n", "stride"),
        ("[filter]\nradius = 3.0\n[filter.curvature]\nkappa = 2.0\ndt = -1.0\n", "dt"),
    ] {
        let f = dir.join("bad.toml");
        std::fs::write(&f, text).unwrap();
        match Settings::from_toml(&f) {
            Err(Error::Parse { offset, reason, .. }) => {
                assert_eq!(&text[offset as usize..offset as usize + key.len()], key, "{reason}");
                assert!(reason.contains(key) && reason.contains("out of range"), "{reason}");
            }
            other => panic!("{text}: {other:?}"),
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A settings file is read section by section over the preset; unknown keys or sections, wrong types and
/// bad names are errors with the file and the byte offset of the offending key or value.
#[test]
fn toml_overrides_the_preset_and_rejects_unknown_keys() {
    let dir = std::env::temp_dir().join(format!("meniscus-settings-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let good = dir.join("good.toml");
    std::fs::write(&good, "[filter]\nfilter = \"bilateral\"\n[filter.narrow]\nradius = 8.0\n").unwrap();
    let s = Settings::preset("moritz").unwrap().with_toml(&good).unwrap();
    assert_eq!(s.filter.narrow.radius, 8.0);
    assert_eq!(s.filter.method, Filter::Bilateral);
    assert_eq!(s.filter.curvature.dt, 0.005); // from the preset, same section as the file's `filter`
    assert_eq!(s.ssr.stride, 8.0); // from the preset
    let check = |name: &str, text: &str, want_offset: usize, want: &str| {
        let f = dir.join(name);
        std::fs::write(&f, text).unwrap();
        let e = Settings::default().with_toml(&f).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains(&format!("byte {want_offset}:")) && e.contains(want), "{e}");
    };
    check("key.toml", "[filter.narrow]\nradiu = 8.0\n", 16, "radiu");
    check("section.toml", "[smoth]\nradius = 8.0\n", 1, "smoth");
    check("type.toml", "[ssr]\nstride = \"far\"\n", 15, "");
    check("name.toml", "[filter]\nfilter = \"gaussien\"\n", 18, "gaussien");
    check("syntax.toml", "[ssr]\nstride = = 8\n", 15, "");
    check("inf.toml", "[iso]\nsmoothing = inf\n", 6, "iso.smoothing: settings are finite numbers");
    check("nan.toml", "[filter.narrow]\nradius = nan\n", 16, "filter.narrow.radius");
    // [noise] values out of range name their key where the [noise] section assigns it (not another
    // section's key of the same name).
    check("noise.toml", "[thickness]\nscale = 0.5\n[noise]\nsize = -1.0\n", 32, "[noise] size = -1");
    check("foam.toml", "[noise]\nwhitecaps_from = 0.5\nwhitecaps_full = 0.2\n", 29, "whitecaps_full = 0.2 must exceed");
    // The old spelling is read as the new one, with a note; both at once is an error.
    let old = dir.join("old.toml");
    std::fs::write(&old, "[noise]\nfoam = 0.4\nfoam_color = [1.0, 0.5, 0.5]\n").unwrap();
    let mut notes = vec![];
    let s = Settings::default().with_toml_noting(&old, &mut notes).unwrap();
    assert_eq!((s.noise.whitecaps, s.noise.whitecaps_color), (0.4, [1.0, 0.5, 0.5]));
    assert!(
        notes.len() == 2 && notes[0].contains("[noise] foam is deprecated: it is spelled whitecaps now"),
        "{notes:?}"
    );
    check("both.toml", "[noise]\nfoam = 0.4\nwhitecaps = 0.5\n", 8, "sets both foam (deprecated) and whitecaps");
    check("noisekey.toml", "[noise]\nsparkle = 1.0\n", 8, "sparkle");
    // A renamed section likewise: `[spray]` is read as `[isolated]`, with a note; both is an error at the old
    // header; a value out of range is found under the header the file wrote.
    let old = dir.join("spray.toml");
    std::fs::write(&old, "[spray]\ndensity = 0.3\nby_neighbours = false\n").unwrap();
    let mut notes = vec![];
    let s = Settings::default().with_toml_noting(&old, &mut notes).unwrap();
    assert_eq!(s.isolated, IsolatedParams { density: 0.3, by_neighbours: false });
    assert!(notes.len() == 1 && notes[0].contains("[spray] is deprecated: it is spelled [isolated] now"), "{notes:?}");
    check("sprayboth.toml", "[isolated]\ndensity = 0.3\n[spray]\ndensity = 0.2\n", 25, "sets both [spray]");
    // The screen-space filter's section was `[smooth]`, its choice `filter`: both still read.
    let old = dir.join("smooth.toml");
    std::fs::write(&old, "[smooth]\nfilter = \"gaussian\"\n[smooth.narrow]\nradius = 8.0\n").unwrap();
    let mut notes = vec![];
    let s = Settings::default().with_toml_noting(&old, &mut notes).unwrap();
    assert_eq!((s.filter.method, s.filter.narrow.radius), (Filter::Gaussian, 8.0));
    assert!(notes.iter().any(|n| n.contains("[smooth] is deprecated: it is spelled [filter] now")), "{notes:?}");
    assert!(notes.iter().any(|n| n.contains("[filter] filter is deprecated: it is spelled method now")), "{notes:?}");
    check("sprayrange.toml", "[iso]\nsmoothing = 1.0\n[spray]\ndensity = 2.0\n", 30, "isolated");
    check(
        "diffuse.toml",
        "[noise]\nsize = 2.0\n[diffuse]\nsize = 1.0\nlifetime = [3.0, 1.0]\n",
        40,
        "lifetime = [3.0, 1.0] is out of range",
    );
    check("diffusekey.toml", "[diffuse]\nglitter = 1\n", 10, "glitter");
}

#[test]
fn presets_pick_their_surfaces() {
    // #15: the default is the smoothed iso surface; fast keeps spheres + narrow-range; quality the exact field.
    let d = Settings::preset("default").unwrap();
    assert_eq!((d.surface, d.filter.method), (Surface::Iso, Filter::None));
    assert!(Settings { radius: 0.01, ..d.clone() }.iso_params().volume.is_some());
    let f = Settings::preset("fast").unwrap();
    assert_eq!((f.surface, f.filter.method), (Surface::Spheres, Filter::NarrowRange));
    let q = Settings { radius: 0.01, ..Settings::preset("quality").unwrap() };
    assert_eq!(q.surface, Surface::Iso);
    assert!(q.iso_params().volume.is_none());
    // The smoothed field is isotropic: anisotropic kernels cast the exact field.
    assert!(Settings { kernel: Kernel::Anisotropic, radius: 0.01, ..d.clone() }.iso_params().volume.is_none());
    // Spheres from unfiltered settings get narrow-range; a filter already chosen stays.
    let mut s = d.clone();
    s.set_surface(Surface::Spheres);
    assert_eq!(s.filter.method, Filter::NarrowRange);
    let mut s = d.with(|s| s.filter.method = Filter::Bilateral);
    s.set_surface(Surface::Spheres);
    assert_eq!(s.filter.method, Filter::Bilateral);
}

#[test]
fn presets_validate() {
    for p in ["default", "fast", "quality", "smooth", "moritz"] {
        let s = Settings { radius: 0.01, ..Settings::preset(p).unwrap() };
        s.validate().unwrap();
    }
    assert!(Settings::preset("nope").is_err());
}

#[test]
fn anisotropy_settings_are_checked_and_reach_the_grid() {
    let s = Settings { radius: 0.01, kernel: Kernel::Anisotropic, ..Settings::default() };
    s.validate().unwrap();
    // The grid's cells reach the kernels: h, stretched, plus the centres' move when they move.
    assert!((s.iso_reach() - 0.04).abs() < 1e-7);
    let moved = s.with(|s| (s.anisotropy.centre_blend, s.anisotropy.stretch) = (0.5, 1.5));
    assert!((moved.iso_reach() - (0.06 + 0.01)).abs() < 1e-6, "{}", moved.iso_reach());
    assert!((s.with(|s| s.kernel = Kernel::Isotropic).iso_reach() - 0.04).abs() < 1e-7);
    for bad in [
        s.with(|s| s.anisotropy.ratio = 0.5),
        s.with(|s| s.anisotropy.centre_blend = 1.5),
        s.with(|s| s.anisotropy.stretch = 4.0),
        s.with(|s| s.anisotropy.radius = 3.0),
        s.with(|s| s.anisotropy.max_shift = -1.0),
    ] {
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("[anisotropy]"), "{e}");
    }
}

#[test]
fn mesh_settings_are_checked() {
    let s = Settings { radius: 0.01, ..Settings::preset("smooth").unwrap() };
    s.validate().unwrap();
    assert_eq!((s.surface, s.mesh.smoothing_iters), (Surface::Mesh, 25));
    for bad in
        [s.with(|s| s.mesh.cube = 0.0), s.with(|s| s.mesh.cube = f32::NAN), s.with(|s| s.mesh.smoothing_iters = 5000)]
    {
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("[mesh]"), "{e}");
    }
}
