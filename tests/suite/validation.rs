//! Scene files: every value the core rejects comes back as an error naming the scene key to change (the loader
//! maps the core's parameter names; it does no range checks of its own). Keys that do not apply to a shape, and
//! unknown names in closed sets, are errors too.

use fissure::scene::Scene;
use std::path::Path;

const BALL: &str = "[[body]]\nshape = \"icosphere\"\nradius = 0.2\n";

/// The error building `text` gives (parse or build), as a string.
fn error(text: &str) -> String {
    match Scene::parse(text, Path::new("inline.toml")) {
        Err(e) => e.to_string(),
        Ok(s) => match s.world::<f32>() {
            Err(e) => e.to_string(),
            Ok(_) => panic!("accepted:\n{text}"),
        },
    }
}

fn assert_names(text: &str, key: &str) {
    let e = error(text);
    assert!(e.contains(&format!("`{key}`")), "expected the key `{key}` in: {e}\n--- scene:\n{text}");
}

#[test]
fn collider_radius_nan_negative_or_zero_names_the_key() {
    for r in ["nan", "-1.0", "0.0", "inf"] {
        assert_names(
            &format!("{BALL}[[collider]]\nshape = \"ball\"\ncenter = [0, 0, 0]\nradius = {r}\n"),
            "collider[0].radius",
        );
        let capsule = format!("[[collider]]\nshape = \"capsule\"\na = [0, 0, 0]\nb = [1, 0, 0]\nradius = {r}\n");
        assert_names(&format!("{BALL}{capsule}"), "collider[0].radius");
    }
}

#[test]
fn zero_normal_names_the_key_and_a_ground_normal_is_an_error() {
    assert_names(
        &format!("{BALL}[[collider]]\nshape = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 0, 0]\n"),
        "collider[0].normal",
    );
    // A ground has no normal: the key was silently ignored before; now it is an error naming it.
    let e = error(&format!("{BALL}[[collider]]\nshape = \"ground\"\nnormal = [1, 0, 0]\n"));
    assert!(e.contains("`collider[0].normal`") && e.contains("does not apply"), "{e}");
    assert_names(&format!("{BALL}[[collider]]\nshape = \"ground\"\nheight = nan\n"), "collider[0].height");
    assert_names(&format!("{BALL}[[collider]]\nshape = \"ground\"\nrestitution = 2.0\n"), "collider[0].restitution");
}

#[test]
fn nan_pressure_is_an_error_not_a_body_without_gas() {
    assert_names(&format!("{BALL}pressure = nan\n"), "body[0].pressure");
    assert_names(&format!("{BALL}pressure = -5.0\n"), "body[0].pressure");
    // 0 still means "no gas".
    let s = Scene::parse(&format!("{BALL}pressure = 0.0\n"), Path::new("inline.toml")).unwrap();
    assert!(!s.world::<f32>().unwrap().model.has_pressure());
}

#[test]
fn negative_mass_and_bad_body_values_name_the_key() {
    assert_names(&format!("{BALL}mass = -1.0\n"), "body[0].mass");
    assert_names(&format!("{BALL}damping_ratio = nan\n"), "body[0].damping_ratio");
    assert_names(&format!("{BALL}strain_limit = -0.1\n"), "body[0].strain_limit");
    let cloth = "[[body]]\nshape = \"cloth\"\nresolution = [4, 4]\nwidth = nan\n";
    assert_names(cloth, "body[0].width");
}

#[test]
fn nan_wind_names_the_key() {
    assert_names(&format!("{BALL}[wind]\nvelocity = [nan, 0, 0]\n"), "wind.velocity");
    assert_names(&format!("{BALL}[wind]\nvelocity = [1, 0, 0]\nair_density = 0.0\n"), "wind.air_density");
}

#[test]
fn non_positive_dt_and_bad_solver_settings_name_the_key() {
    for dt in ["0.0", "-1e-4", "nan"] {
        assert_names(&format!("[solver]\ndt = {dt}\n{BALL}"), "solver.dt");
    }
    let e = error(&format!("[solver]\nsubstep_safety = 2.0\n{BALL}"));
    assert!(e.contains("substep_safety"), "{e}");
    assert_names(&format!("[solver]\ngravity = [0, nan, 0]\n{BALL}"), "solver.gravity");
    assert_names(&format!("[fracture]\ngas_density = 0.0\n{BALL}"), "fracture.gas_density");
}

#[test]
fn keys_that_do_not_apply_to_a_body_shape_are_errors() {
    let e = error("[[body]]\nshape = \"icosphere\"\nradius = 0.2\nhalf_extents = [1, 1, 1]\n");
    assert!(e.contains("`body[0].half_extents`") && e.contains("does not apply"), "{e}");
    let e = error("[[body]]\nshape = \"cuboid\"\nhalf_extents = [0.1, 0.1, 0.1]\nradius = 0.2\n");
    assert!(e.contains("`body[0].radius`") && e.contains("does not apply"), "{e}");
    let e = error("[[body]]\nshape = \"cloth\"\nresolution = [4, 4]\nsubdivisions = 2\n");
    assert!(e.contains("`body[0].subdivisions`"), "{e}");
}

#[test]
fn closed_sets_are_enums_and_unknown_names_are_listed() {
    let e = error(&format!("[solver]\nintegrator = \"euler\"\n{BALL}"));
    assert!(e.contains("euler") && e.contains("symplectic_euler"), "{e}");
    let e = error("[[body]]\nshape = \"sphere\"\nradius = 0.2\n");
    assert!(e.contains("sphere") && e.contains("icosphere"), "{e}");
    let e = error(&format!("{BALL}[[collider]]\nshape = \"disc\"\n"));
    assert!(e.contains("disc") && e.contains("capsule"), "{e}");
}

#[test]
fn a_blow_up_names_the_scene_key_to_change() {
    // Stiff springs at a large step: the message names `solver.substep_safety`, which a scene user can set.
    let text = format!("[solver]\ndt = 0.01\n{BALL}stiffness = 1e6\n");
    let s = Scene::parse(&text, Path::new("inline.toml")).unwrap();
    let mut w = s.world::<f32>().unwrap();
    let e = w.advance(1.0, 0.01).expect_err("blows up").to_string();
    assert!(e.contains("solver.substep_safety"), "{e}");
}
