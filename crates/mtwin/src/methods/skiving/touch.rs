//! A touch-off as a measurement model: one exact contact condition on the
//! chain of [`super::chain`], in the unit mm.
//!
//! * top face, tool face centre: `r = gP_z` (the point lies in the plane
//!   `z = 0` of the workpiece frame);
//! * side, tool tip: `r = √(gP_x² + gP_y²) − rg` (the point lies on the
//!   cylinder of radius `rg` about the workpiece z axis).
//!
//! [`TouchModel`] implements [`crate::fit::Model`] with one block (one row)
//! per touch, grouped `top` and `side`.

use std::ops::Range;

use faer::MatMut;
use nalgebra::Vector3;

use super::chain::{AxisPositions, Geometry, SetupError, point_with_derivatives};
use crate::fit::{BlockLayout, Model, Parameter};
use crate::io::{Diagnostic, Diagnostics, Table};

/// The tool point that makes contact, in the tool frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ToolPoint {
    /// Tool face centre, `tP = (0, 0, 0)`.
    Face,
    /// Tool tip, `tP = (0, −rt, 0)`.
    Tip,
}

impl ToolPoint {
    /// The point in the tool frame (mm).
    pub fn position(self, g: &Geometry) -> Vector3<f64> {
        match self {
            ToolPoint::Face => Vector3::zeros(),
            ToolPoint::Tip => Vector3::new(0.0, -g.rt(), 0.0),
        }
    }

    /// The name used in TOUCHES.csv.
    pub fn name(self) -> &'static str {
        match self {
            ToolPoint::Face => "face",
            ToolPoint::Tip => "tip",
        }
    }
}

/// The workpiece surface touched.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Contact {
    /// The top face `gP_z = 0`.
    Top,
    /// The side cylinder `√(gP_x² + gP_y²) = rg`.
    Side,
}

impl Contact {
    /// The name used in TOUCHES.csv.
    pub fn name(self) -> &'static str {
        match self {
            Contact::Top => "top",
            Contact::Side => "side",
        }
    }
}

/// One recorded touch-off: the axis positions at contact, the tool point
/// and the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Touch {
    /// Axis positions at contact (mm, degrees).
    pub at: AxisPositions,
    /// The point of the tool that touched.
    pub point: ToolPoint,
    /// The workpiece surface touched.
    pub contact: Contact,
}

impl Touch {
    /// The tool point in the workpiece frame (mm) at set-up errors `e`.
    pub fn point_in_workpiece(&self, g: &Geometry, e: &SetupError) -> Vector3<f64> {
        point_with_derivatives(&self.at, g, e, &self.point.position(g)).0
    }

    /// The contact condition's residual (mm): 0 when the touch is exactly
    /// explained by `e`.
    pub fn residual(&self, g: &Geometry, e: &SetupError) -> f64 {
        self.residual_and_gradient(g, e).0
    }

    /// The residual and its exact gradient with respect to
    /// `[dgx, dgy, exz, ezy]` (mm per mm, mm per rad).
    pub fn residual_and_gradient(&self, g: &Geometry, e: &SetupError) -> (f64, [f64; 4]) {
        let (gp, d) = point_with_derivatives(&self.at, g, e, &self.point.position(g));
        match self.contact {
            Contact::Top => (gp.z, d.map(|v| v.z)),
            Contact::Side => {
                let rho = gp.x.hypot(gp.y);
                // rho > 0 for every touch accepted by `plausibility`.
                let grad = d.map(|v| (gp.x * v.x + gp.y * v.y) / rho);
                (rho - g.rg(), grad)
            }
        }
    }

    /// Checks that the tool point is near the stated surface when the
    /// set-up errors are zero (they are small by assumption): within
    /// `tolerance` mm of it, and for a top touch inside the blank's rim
    /// widened by the tool radius, for a side touch below the top face.
    pub fn plausibility(&self, g: &Geometry, tolerance: f64) -> Result<(), String> {
        let p = self.point_in_workpiece(g, &SetupError::default());
        let rho = p.x.hypot(p.y);
        let r = self.residual(g, &SetupError::default());
        let surface = match self.contact {
            Contact::Top => "top face",
            Contact::Side => "side cylinder",
        };
        if r.is_nan() || r.abs() > tolerance {
            return Err(format!(
                "the tool {} is {:.3} mm from the workpiece {surface} at these axis positions \
                 (more than {tolerance} mm): this contact is impossible",
                self.point.name(),
                r
            ));
        }
        match self.contact {
            Contact::Top if rho > g.rg() + g.rt() => Err(format!(
                "the tool face centre is {rho:.3} mm from the workpiece axis, so the tool \
                 (radius {}) does not overlap the top face (radius {}): this contact is impossible",
                g.rt(),
                g.rg()
            )),
            Contact::Side if p.z > tolerance => Err(format!(
                "the tool tip is {:.3} mm above the top face: it cannot touch the side",
                p.z
            )),
            _ => Ok(()),
        }
    }
}

/// Default distance (mm) a touch may lie from its surface at zero set-up
/// error before it is rejected as impossible.
pub const DEFAULT_PLAUSIBILITY_MM: f64 = 1.0;

/// Reads `x,y,z,a,b,c,point,contact` (mm, degrees; `point` = `face`|`tip`,
/// `contact` = `top`|`side`), one touch per row, in file order, and rejects
/// touches that cannot be contacts ([`Touch::plausibility`]). Every
/// problem is reported with file and line.
pub fn read_touches(t: &Table, g: &Geometry, tolerance: f64) -> Result<Vec<Touch>, Diagnostics> {
    let nums = t.number_rows(&crate::io::columns::SKIVING_TOUCH_POSITION)?;
    let cols = t
        .require(&crate::io::columns::SKIVING_TOUCH_LABELS)
        .map_err(Diagnostics::from)?;
    let mut diags = Diagnostics::default();
    let mut out = Vec::with_capacity(t.len());
    for (row, n) in nums.iter().enumerate() {
        let point = match t.text(row, cols[0]) {
            "face" => Some(ToolPoint::Face),
            "tip" => Some(ToolPoint::Tip),
            other => {
                diags.push(t.cell_error(
                    row,
                    cols[0],
                    format!("unknown tool point `{other}`; expected `face` or `tip`"),
                ));
                None
            }
        };
        let contact = match t.text(row, cols[1]) {
            "top" => Some(Contact::Top),
            "side" => Some(Contact::Side),
            other => {
                diags.push(t.cell_error(
                    row,
                    cols[1],
                    format!("unknown contact type `{other}`; expected `top` or `side`"),
                ));
                None
            }
        };
        let (Some(point), Some(contact)) = (point, contact) else {
            continue;
        };
        let touch = Touch {
            at: AxisPositions {
                x: n[0],
                y: n[1],
                z: n[2],
                a: n[3],
                b: n[4],
                c: n[5],
            },
            point,
            contact,
        };
        match touch.plausibility(g, tolerance) {
            Ok(()) => out.push(touch),
            Err(msg) => diags.push(t.row_error(row, msg)),
        }
    }
    if out.is_empty() && diags.is_empty() {
        diags.push(Diagnostic::whole(t.path(), "the file holds no touches"));
    }
    diags.into_result(out)
}

/// The touches as a least-squares model over `[dgx, dgy, exz, ezy]`, one
/// residual row (mm) per touch. All touches have the same noise, so the rows
/// are not weighted.
pub struct TouchModel<'a> {
    touches: &'a [Touch],
    geometry: Geometry,
}

impl<'a> TouchModel<'a> {
    /// The model of `touches` on a machine of geometry `geometry`.
    pub fn new(touches: &'a [Touch], geometry: Geometry) -> Self {
        Self { touches, geometry }
    }
}

impl Model for TouchModel<'_> {
    fn parameters(&self) -> Vec<Parameter> {
        vec![
            Parameter::with_scale("dgx", 1e-2),
            Parameter::with_scale("dgy", 1e-2),
            Parameter::with_scale("exz", 1e-4),
            Parameter::with_scale("ezy", 1e-4),
        ]
    }

    fn layout(&self) -> BlockLayout {
        let mut l = BlockLayout::new();
        for t in self.touches {
            l = l.push_group(t.contact.name(), 1, 1);
        }
        l
    }

    fn evaluate(
        &self,
        theta: &[f64],
        rows: Range<usize>,
        r: Option<&mut [f64]>,
        j: Option<MatMut<'_, f64>>,
    ) {
        let e = SetupError::from_slice(theta);
        if let Some(out) = r {
            for (o, t) in out.iter_mut().zip(&self.touches[rows.clone()]) {
                *o = t.residual(&self.geometry, &e);
            }
        }
        if let Some(mut out) = j {
            for (i, t) in self.touches[rows].iter().enumerate() {
                let (_, g) = t.residual_and_gradient(&self.geometry, &e);
                for (k, gk) in g.iter().enumerate() {
                    out[(i, k)] = *gk;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::check_jacobian;
    use proptest::prelude::*;
    use std::path::Path;

    fn geometry() -> Geometry {
        Geometry::new(80.0, 150.0, 40.0, 60.0).unwrap()
    }

    fn table(text: &str) -> Table {
        Table::from_reader(Path::new("T.csv"), text.as_bytes()).unwrap()
    }

    const HEADER: &str = "x,y,z,a,b,c,point,contact\n";

    #[test]
    fn model_jacobian_matches_differences() {
        let g = geometry();
        let touches = [
            Touch {
                at: AxisPositions {
                    y: 30.0,
                    z: -80.01,
                    c: 0.0,
                    ..Default::default()
                },
                point: ToolPoint::Face,
                contact: Contact::Top,
            },
            Touch {
                at: AxisPositions {
                    x: 2.0,
                    y: 100.02,
                    z: -90.0,
                    a: 3.0,
                    b: -2.0,
                    c: 90.0,
                },
                point: ToolPoint::Tip,
                contact: Contact::Side,
            },
        ];
        let m = TouchModel::new(&touches, g);
        let c = check_jacobian(&m, &[0.02, -0.03, 2e-4, -1e-4]).unwrap();
        assert!(c.passes(1e-6), "{c:?}");
    }

    #[test]
    fn side_residual_is_the_radial_distance_minus_rg() {
        // Nominal side touch at c = 0: tip at machine (0, y − rt, z), the
        // workpiece axis at x = 0: radial distance y − rt.
        let g = geometry();
        let t = Touch {
            at: AxisPositions {
                y: 100.25,
                z: -90.0,
                ..Default::default()
            },
            point: ToolPoint::Tip,
            contact: Contact::Side,
        };
        assert!((t.residual(&g, &SetupError::default()) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn reader_accepts_good_rows_and_reports_bad_ones_with_lines() {
        let g = geometry();
        let ok = table(&format!(
            "{HEADER}0,30,-80,0,0,0,face,top\n# comment\n0,100,-90,0,0,90,tip,side\n"
        ));
        let t = read_touches(&ok, &g, 1.0).unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(t[1].contact, Contact::Side);
        assert_eq!(t[1].at.c, 90.0);

        let bad = table(&format!(
            "{HEADER}0,30,-80,0,0,0,face,bottom\n0,30,-70,0,0,0,face,top\n0,30,-80,0,0,0,edge,top\n"
        ));
        let d = read_touches(&bad, &g, 1.0).unwrap_err().to_string();
        assert!(
            d.contains("T.csv:2:8: unknown contact type `bottom`"),
            "{d}"
        );
        assert!(
            d.contains("T.csv:3: the tool face is 10.000 mm from the workpiece top face"),
            "{d}"
        );
        assert!(d.contains("T.csv:4:7: unknown tool point `edge`"), "{d}");

        let missing = table("x,y,z,a,b,c,point\n0,30,-80,0,0,0,face\n");
        let d = read_touches(&missing, &g, 1.0).unwrap_err().to_string();
        assert!(d.contains("T.csv:1: missing column `contact`"), "{d}");
    }

    #[test]
    fn reader_rejects_face_touch_beyond_the_rim_and_side_touch_above_the_face() {
        let g = geometry();
        let far = table(&format!("{HEADER}0,150,-80,0,0,0,face,top\n"));
        let d = read_touches(&far, &g, 1.0).unwrap_err().to_string();
        assert!(d.contains("does not overlap the top face"), "{d}");
        let above = table(&format!("{HEADER}0,100,-75,0,0,0,tip,side\n"));
        let d = read_touches(&above, &g, 1.0).unwrap_err().to_string();
        assert!(d.contains("above the top face"), "{d}");
    }

    proptest! {
        #[test]
        fn reader_never_panics(s in "[-0-9a-z.,\n ]{0,200}") {
            if let Ok(t) = Table::from_reader(Path::new("p.csv"), format!("{HEADER}{s}").as_bytes()) {
                let _ = read_touches(&t, &geometry(), 1.0);
            }
        }
    }
}
