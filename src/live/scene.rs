//! Each fingertip's pin field as a Foxglove well-known scene (`foxglove.SceneUpdate`), for
//! the live view's 3D panel: a sphere per pin, coloured by the classifier's latest output
//! for that sensor. Served live only; the logs keep the plain `x[]`, `y[]` frames (a scene
//! per frame would double a log's bytes), from which a viewer's plots draw the same field.

use foxglove::messages::{
    Color, Pose, Quaternion, SceneEntity, SceneUpdate, SpherePrimitive, Vector3,
};
use tmo_hal::PinFrame;

use crate::slip::Class;

/// The scene's one frame of reference; the fingertips lie side by side in it.
pub const SCENE_FRAME: &str = "tactile";
/// The scene channel's topic.
pub const SCENE_TOPIC: &str = "/tactile/scene";

/// Scene units per image pixel: 1 px is drawn as 1 mm, so a 340 px image is 0.34 m wide.
const M_PER_PX: f64 = 0.001;
/// How far apart the fingertips are drawn, px (wider than a TacTip image).
const SENSOR_SPACING_PX: f64 = 400.0;
/// A pin's sphere, px across.
const PIN_SIZE_PX: f64 = 8.0;

/// The colour of a fingertip's pins given its latest class (none yet: grey).
pub fn pin_colour(class: Option<Class>) -> Color {
    let (r, g, b) = match class {
        Some(Class::Slip) => (0.85, 0.15, 0.15),
        Some(Class::Static) => (0.2, 0.45, 0.8),
        None => (0.6, 0.6, 0.6),
    };
    Color { r, g, b, a: 1.0 }
}

/// The scene entity `pins/<sensor>` of `frame`, which replaces that sensor's previous one:
/// image y (down) drawn as scene -y, so the field looks as it does in the camera.
pub fn pin_scene(frame: &PinFrame, class: Option<Class>) -> SceneUpdate {
    let colour = pin_colour(class);
    let offset = f64::from(frame.sensor) * SENSOR_SPACING_PX;
    let size = PIN_SIZE_PX * M_PER_PX;
    let spheres = frame
        .pins
        .iter()
        .map(|[x, y]| SpherePrimitive {
            pose: Some(Pose {
                position: Some(Vector3 {
                    x: (offset + f64::from(*x)) * M_PER_PX,
                    y: -f64::from(*y) * M_PER_PX,
                    z: 0.0,
                }),
                orientation: Some(Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                    w: 1.0,
                }),
            }),
            size: Some(Vector3 {
                x: size,
                y: size,
                z: size,
            }),
            color: Some(colour),
        })
        .collect();
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![SceneEntity {
            frame_id: SCENE_FRAME.into(),
            id: format!("pins/{}", frame.sensor),
            spheres,
            ..SceneEntity::default()
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_is_one_entity_of_a_sphere_per_pin_coloured_by_its_class() {
        let frame = PinFrame {
            sensor: 2,
            seq: 9,
            time_s: 0.1,
            pins: vec![[10.0, 20.0], [30.0, 40.0]],
        };
        let scene = pin_scene(&frame, Some(Class::Slip));
        assert_eq!(scene.entities.len(), 1);
        let entity = &scene.entities[0];
        assert_eq!(
            (entity.id.as_str(), entity.frame_id.as_str()),
            ("pins/2", "tactile")
        );
        assert_eq!(entity.spheres.len(), 2);
        let p = entity.spheres[1].pose.unwrap().position.unwrap();
        // sensor 2 sits two spacings along x; image y points down, the scene's up
        assert!((p.x - (800.0 + 30.0) * 0.001).abs() < 1e-12 && (p.y + 0.040).abs() < 1e-12);
        assert_eq!(entity.spheres[0].color, Some(pin_colour(Some(Class::Slip))));
        assert_ne!(
            pin_colour(Some(Class::Static)),
            pin_colour(Some(Class::Slip))
        );
        assert_ne!(pin_colour(None), pin_colour(Some(Class::Static)));
    }
}
