//! A cell's rangefinder, cast only where it can see something: MuJoCo's
//! `rangefinder` casts its ray against every geom of the model in every
//! step, yet the VCNL4010 reads zero beyond its range. A ray whose first
//! `reach` metres pass no geom's bounding sphere reads the same as a ray
//! that hits nothing, so it is not cast; any other is cast by MuJoCo's own
//! `mj_ray`, with the rangefinder's arguments (the site's z axis, static
//! geoms seen, the site's own body not), so the reading is MuJoCo's.

use mujoco_rs::prelude::*;
use nalgebra::{Point3, Vector3};

/// The first geom MuJoCo's rangefinder at the site `site` on `body` sees
/// along its z axis, and its distance, m, in the state MuJoCo last
/// computed (the last step's); `None` when nothing lies within `reach`,
/// where a rangefinder may read a farther hit or none.
pub(super) fn distance(data: &mut MjData<Box<MjModel>>, site: usize, body: usize, reach: f64) -> Option<(usize, f64)> {
    let (p, m) = (data.site_xpos()[site], data.site_xmat()[site]);
    let (from, along) = (Point3::from(p), Vector3::new(m[2], m[5], m[8]));
    if !sees_anything(data, &from, &along, body, reach) {
        return None;
    }
    let (geom, dist) = data.ray(&p, &along.into(), None, true, Some(body), None);
    geom.filter(|_| dist >= 0.0).map(|g| (g, dist))
}

/// Whether the segment from `from` along the unit `along` for `reach`
/// passes through the bounding sphere of a geom not on `body` (a geom
/// without one, a plane, always counts).
fn sees_anything(
    data: &MjData<Box<MjModel>>,
    from: &Point3<f64>,
    along: &Vector3<f64>,
    body: usize,
    reach: f64,
) -> bool {
    let model = data.model();
    let (bodies, bounds, centres) = (model.geom_bodyid(), model.geom_rbound(), data.geom_xpos());
    (0..bounds.len()).any(|g| {
        if bodies[g] as usize == body {
            return false;
        }
        let radius = bounds[g];
        if radius <= 0.0 {
            return true;
        }
        let to = Point3::from(centres[g]) - from;
        let t = to.dot(along).clamp(0.0, reach);
        (to - along * t).norm_squared() <= radius * radius
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sites on a body's box facing out, each with MuJoCo's rangefinder: one
    /// at a wall 0.1 m off, one at a ball 0.46 m off, one at nothing, and
    /// one at a wall 0.2 m off behind a geom of its own body.
    const MODEL: &str = r#"
<mujoco>
  <worldbody>
    <geom name="wall" type="box" pos="0.2 0 0" size="0.01 0.05 0.05"/>
    <geom name="ball" type="sphere" pos="0 0 0.6" size="0.05"/>
    <geom name="far_wall" type="box" pos="0 -0.3 0" size="0.05 0.01 0.05"/>
    <body name="arm">
      <geom type="box" size="0.09 0.09 0.09"/>
      <geom type="sphere" pos="0 -0.15 0" size="0.03"/>
      <site name="to_wall" pos="0.09 0 0" zaxis="1 0 0"/>
      <site name="to_ball" pos="0 0 0.09" zaxis="0 0 1"/>
      <site name="to_nothing" pos="-0.09 0 0" zaxis="-1 0 0"/>
      <site name="past_own" pos="0 -0.09 0" zaxis="0 -1 0"/>
    </body>
  </worldbody>
  <sensor>
    <rangefinder site="to_wall"/>
    <rangefinder site="to_ball"/>
    <rangefinder site="to_nothing"/>
    <rangefinder site="past_own"/>
  </sensor>
</mujoco>"#;

    #[test]
    fn a_ray_is_cast_only_where_something_is_in_reach_and_reads_as_mujocos_rangefinder() {
        let model = MjModel::from_xml_string(MODEL).expect("MuJoCo loads the test model");
        let mut data = MjData::new(Box::new(model));
        data.forward();
        let body = data.model().name_to_id(MjtObjBase::mjOBJ_BODY, "arm").expect("the arm");
        let sensed: Vec<f64> = data.sensordata().to_vec();
        let reach = 0.25;
        let ours: Vec<Option<f64>> =
            (0..4).map(|site| distance(&mut data, site, body, reach).map(|(_, d)| d)).collect();
        // In reach: MuJoCo's own reading, to the bit; the site's own body
        // is not seen, as MuJoCo's rangefinder does not see it.
        assert_eq!(ours[0], Some(sensed[0]));
        assert!((sensed[0] - 0.1).abs() < 1e-12, "{sensed:?}");
        assert_eq!(ours[3], Some(sensed[3]));
        assert!((sensed[3] - 0.2).abs() < 1e-12, "{sensed:?}");
        // Beyond reach: not cast, where MuJoCo reads a far hit or none.
        assert!((sensed[1] - 0.46).abs() < 1e-12 && ours[1].is_none(), "{sensed:?} {ours:?}");
        assert!(sensed[2] < 0.0 && ours[2].is_none(), "{sensed:?} {ours:?}");
        // A reach past the ball casts, and reads what MuJoCo reads.
        let ball = data.model().name_to_id(MjtObjBase::mjOBJ_GEOM, "ball");
        assert_eq!(distance(&mut data, 1, body, 0.5), ball.map(|g| (g, sensed[1])));
    }
}
