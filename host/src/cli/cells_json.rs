//! The calibrated cells as JSON, for `skin calibrate --json` and
//! `skin replay --calibrate FILE --json`.

use serde_json::{json, Value};
use skin_host::calibrate::Calibration;

/// Every cell's calibrated pose and sensor, as JSON.
pub fn cells_json(c: &Calibration) -> Vec<Value> {
    c.cells
        .iter()
        .map(|p| {
            let observable: Vec<&str> =
                ["x", "y", "z"].into_iter().zip(p.observable()).filter(|(_, o)| *o).map(|(a, _)| a).collect();
            json!({
                "id": p.id.0,
                "link": p.link,
                "xyz": p.position.as_slice(),
                "rpy": p.rpy(),
                "observable": observable,
                "unobservable_directions": p.unobservable.iter().map(|v| v.as_slice().to_vec()).collect::<Vec<_>>(),
                "from_neighbours_directions": p.from_neighbours.iter().map(|v| v.as_slice().to_vec()).collect::<Vec<_>>(),
                "position_sigma_m": p.position_sigma_m.iter().map(|&s| finite_or_null(s)).collect::<Vec<_>>(),
                "orientation_observable": p.orientation_observable,
                "orientation_sigma_deg": finite_or_null(p.orientation_sigma_rad.to_degrees()),
                "gain": p.gain.as_slice(),
                "offset_mps2": p.offset_mps2.as_slice(),
                "motion_residual_mps2": finite_or_null(p.motion_residual_mps2),
                "inconsistent": p.inconsistent,
                "ambiguous_with": p.ambiguous_with,
            })
        })
        .collect()
}

fn finite_or_null(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}
