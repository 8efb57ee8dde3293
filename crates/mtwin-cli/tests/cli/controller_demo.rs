//! The residual report on the demo's identified machines: the gantry
//! identified from the tracker step and the trunnion (the PIGEs the ballbar
//! step identifies, and the full error model the demo compensates with), for
//! every format. The table printed here is the one in
//! docs/controller-tables.md.

use mtwin::controller::{self, ExportOptions, Format, Residual, ResidualOptions};
use mtwin::model::Machine;
use mtwin::scenarios::{gantry_tracker, trunnion_ballbar};

fn demo_gantry() -> Machine {
    let truth = mtwin::examples::machine("afp-gantry-with-errors").unwrap();
    let nominal = mtwin::examples::machine("afp-gantry").unwrap();
    gantry_tracker::run(&truth, &nominal, &Default::default())
        .unwrap()
        .identification
        .machine
}

fn demo_trunnion_ballbar() -> Machine {
    let nominal = mtwin::examples::machine("ac-trunnion").unwrap();
    let errors = mtwin::examples::machine("ac-trunnion-with-errors").unwrap();
    let run = trunnion_ballbar::run(&nominal, &errors, &Default::default()).unwrap();
    let t = mtwin::methods::ballbar::Trunnion::of(&nominal).unwrap();
    let mut m = nominal.clone();
    run.identification.piges.write_to(&mut m, &t);
    m
}

fn residuals(m: &Machine) -> Vec<(Format, Result<Residual, String>)> {
    Format::ALL
        .into_iter()
        .map(|f| {
            let r = controller::export(m, f, &ExportOptions::default())
                .map(|e| controller::residual(m, &e.correction, &ResidualOptions::default()))
                .map_err(|e| e.to_string());
            (f, r)
        })
        .collect()
}

fn print(name: &str, rows: &[(Format, Result<Residual, String>)]) {
    eprintln!("{name}");
    for (f, r) in rows {
        match r {
            Ok(r) => eprintln!(
                "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.4} | {:?} |",
                f.name(),
                r.uncompensated_max_um,
                r.uncompensated_rms_um,
                r.max_um,
                r.rms_um,
                r.full_model_max_um,
                r.at
            ),
            Err(e) => eprintln!("| {} | {e} |", f.name()),
        }
    }
}

fn get(rows: &[(Format, Result<Residual, String>)], f: Format) -> &Residual {
    rows.iter()
        .find(|r| r.0 == f)
        .unwrap()
        .1
        .as_ref()
        .unwrap_or_else(|e| panic!("{}: {e}", f.name()))
}

#[test]
fn residual_report_on_the_demo_machines() {
    let trunnion_full = mtwin::examples::machine("ac-trunnion-with-errors").unwrap();
    for (name, m) in [
        ("gantry identified (tracker step)", demo_gantry()),
        (
            "trunnion, PIGEs identified (ballbar step)",
            demo_trunnion_ballbar(),
        ),
        ("trunnion with errors (compensation step)", trunnion_full),
    ] {
        let rows = residuals(&m);
        print(name, &rows);
        for (f, r) in &rows {
            let r = r
                .as_ref()
                .unwrap_or_else(|e| panic!("{name} {}: {e}", f.name()));
            // Compensating with the full model leaves nothing (solver tolerance).
            assert!(
                r.full_model_max_um < 1e-3,
                "{name}: {}",
                r.full_model_max_um
            );
            assert!(r.max_um.is_finite() && r.rms_um <= r.max_um);
        }
        // The volumetric formats carry the whole model: what is left is
        // table interpolation, far below the error itself.
        for f in [Format::Isg, Format::Etalon] {
            let r = get(&rows, f);
            assert!(
                r.max_um < 0.02 * r.uncompensated_max_um,
                "{name} {}: {r:?}",
                f.name()
            );
        }
    }
    // The ballbar's PIGEs: LinuxCNC's trunnion parameters carry the four
    // axis-line offsets; the four tilts are left (far from the pivots they
    // dominate the maximum). With the four offsets alone the trunnion
    // parameters leave nothing.
    let m = demo_trunnion_ballbar();
    let rows = residuals(&m);
    let lc = get(&rows, Format::LinuxCnc);
    let eec = get(&rows, Format::SiemensEec);
    assert!(lc.rms_um < 0.8 * lc.uncompensated_rms_um, "{lc:?}");
    assert!(lc.rms_um < eec.rms_um, "{lc:?} vs {eec:?}");
    let mut offsets_only = mtwin::examples::machine("ac-trunnion").unwrap();
    for n in mtwin::controller::linuxcnc_comp::Trunnion::Xyzac.carried() {
        let i = m.axis_index(&n.axis).unwrap();
        offsets_only.axes[i].errors.location[n.component.index()] =
            m.axes[i].errors.location[n.component.index()];
    }
    let rows = residuals(&offsets_only);
    let lc = get(&rows, Format::LinuxCnc);
    assert!(lc.uncompensated_max_um > 10.0, "{lc:?}");
    assert!(lc.max_um < 1e-3, "{lc:?}");
}
