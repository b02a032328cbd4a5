//! The built-in scene registry: one list ([`BUILT_IN`]) that the parser
//! [`built_in`] dispatches on and help texts print, so a name, its
//! parameters and its description cannot drift apart.

use std::ops::RangeInclusive;

use glam::DVec3;

use super::{Limits, Material, Scene, SceneError, SphereCells, sphere_patches};
use crate::camera::Camera;

/// One built-in scene.
pub struct BuiltIn {
    /// Name before the first `:`.
    pub name: &'static str,
    /// Full syntax with parameters, `[...]` optional (`"sphere[:B,S]"`).
    pub syntax: &'static str,
    /// One-line description with parameter ranges and defaults.
    pub description: &'static str,
    /// The scene's own view (scene units), if it has one: the default
    /// camera of `render` and of `radiosity`'s pictures.
    pub camera: Option<DefaultCamera>,
    /// `radiosity`'s pictures' camera where it is not [`BuiltIn::camera`]:
    /// those pictures see the first surface that faces the eye and look
    /// through back faces, so they can stand outside a closed scene and
    /// look through its wall, which the path tracer cannot (it refuses an
    /// eye that sees the scene's walls from behind). `None`: `camera`.
    pub picture_camera: Option<DefaultCamera>,
    build: fn(&Args) -> Result<Scene, SceneError>,
}

/// A built-in scene's default view: eye, target (up is +y) and the vertical field of view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DefaultCamera {
    /// Eye position.
    pub eye: [f64; 3],
    /// Point looked at.
    pub target: [f64; 3],
    /// Vertical field of view in degrees.
    pub fov_deg: f64,
}

impl DefaultCamera {
    /// The camera, up +y.
    ///
    /// # Panics
    /// Never for the registry's cameras (a test builds every one).
    #[must_use]
    pub fn camera(&self) -> Camera {
        let d = DVec3::from_array;
        Camera::look_at(d(self.eye), d(self.target), DVec3::Y, self.fov_deg).expect("the registry's cameras are valid")
    }
}

/// A scene's own view: the camera its file gives (glTF, Mitsuba 3), else
/// `pick` of its built-in's registry entry (the entry of
/// [`Scene::base_name`], so a subdivided scene keeps its view); `None` when
/// it has neither.
#[must_use]
pub fn scene_camera(scene: &Scene, pick: fn(&BuiltIn) -> Option<DefaultCamera>) -> Option<Camera> {
    scene.camera.or_else(|| BuiltIn::of(scene.base_name()).and_then(pick).map(|c| c.camera()))
}

impl BuiltIn {
    /// The camera of `radiosity`'s pictures: [`BuiltIn::picture_camera`], else [`BuiltIn::camera`].
    #[must_use]
    pub fn radiosity_camera(&self) -> Option<DefaultCamera> {
        self.picture_camera.or(self.camera)
    }

    /// The registry entry of a scene spec (`"mirror-room:3"` → `mirror-room`), if it is a built-in
    /// (give [`Scene::base_name`] for a subdivided scene).
    #[must_use]
    pub fn of(spec: &str) -> Option<&'static BuiltIn> {
        let name = spec.split(':').next().unwrap_or_default();
        BUILT_IN.iter().find(|b| b.name == name)
    }
}

/// Every built-in scene, in help order.
pub const BUILT_IN: &[BuiltIn] = &[
    BuiltIn {
        name: "cube-enclosure",
        syntax: "cube-enclosure[:N]",
        description: "inside of the unit cube, each face split into N x N squares, N in 1..=1000 (default 10; Part III Fig. 13)",
        camera: None,
        picture_camera: None,
        build: cube_enclosure,
    },
    BuiltIn {
        name: "tetrahedron",
        syntax: "tetrahedron",
        description: "regular tetrahedron seen from inside, one patch per face (Table 4)",
        camera: None,
        picture_camera: None,
        build: solid,
    },
    BuiltIn {
        name: "cube",
        syntax: "cube",
        description: "cube seen from inside, one patch per face (Table 4)",
        camera: None,
        picture_camera: None,
        build: solid,
    },
    BuiltIn {
        name: "octahedron",
        syntax: "octahedron",
        description: "regular octahedron seen from inside, one patch per face (Table 4)",
        camera: None,
        picture_camera: None,
        build: solid,
    },
    BuiltIn {
        name: "dodecahedron",
        syntax: "dodecahedron",
        description: "regular dodecahedron seen from inside, one patch per face (Table 4)",
        camera: None,
        picture_camera: None,
        build: solid,
    },
    BuiltIn {
        name: "icosahedron",
        syntax: "icosahedron",
        description: "regular icosahedron seen from inside, one patch per face (Table 4)",
        camera: None,
        picture_camera: None,
        build: solid,
    },
    BuiltIn {
        name: "sphere",
        syntax: "sphere[:B,S]",
        description: "exact sphere seen from inside, B z-bands x S sectors of equal area, B and S in 1..=4096 (default 8,16)",
        camera: None,
        picture_camera: None,
        build: sphere,
    },
    BuiltIn {
        name: "cornell-box",
        syntax: "cornell-box",
        description: "closed Cornell box from the published measurements: 5 walls, front closed, light, two blocks (after Fig. 20a)",
        // Just inside the closed front wall.
        camera: Some(DefaultCamera { eye: [278.0, 273.0, 15.0], target: [278.0, 273.0, 559.2], fov_deg: 54.0 }),
        // The published camera (Fig. 20a): outside, looking through the closed front wall.
        picture_camera: Some(DefaultCamera { eye: [278.0, 273.0, -800.0], target: [278.0, 273.0, 0.0], fov_deg: 39.3 }),
        build: cornell_box,
    },
    BuiltIn {
        name: "geosphere",
        syntax: "geosphere[:L]",
        description: "unit geodesic sphere seen from outside, 20*4^(L-1) triangles, L in 1..=9 (default 2: 80)",
        camera: None,
        picture_camera: None,
        build: geosphere,
    },
    BuiltIn {
        name: "torus",
        syntax: "torus[:U,V]",
        description: "ring torus (radii 1 and 0.4) seen from outside, U x V quads, U and V in 3..=4096 (default 48,24)",
        camera: None,
        picture_camera: None,
        build: torus,
    },
    BuiltIn {
        name: "table-chairs",
        syntax: "table-chairs[:N]",
        description: "a table with four chairs, 29 boxes seen from outside, faces split N x N, N in 1..=256 (default 2)",
        camera: None,
        picture_camera: None,
        build: table_chairs,
    },
    BuiltIn {
        name: "cubes-room",
        syntax: "cubes-room[:K][:clustered|random][:SEED]",
        description: "cube enclosure 10x10 per face with K cubes of side 0.05, random (K in 1..=1000, default) or clustered (K in 1..=2197); default K = 27, SEED = 1 (Figs. 11, 15, 16)",
        camera: None,
        picture_camera: None,
        build: cubes_room,
    },
    BuiltIn {
        name: "mirror-room",
        syntax: "mirror-room[:L]",
        description: "closed 4x3x5 room with a ceiling area light, a mirrored pyramid, a mirrored sphere (geodesic, level L in 1..=6, default 5: 5,120 triangles) and two diffuse blocks (after Part IV Figs. 7, 11)",
        // From the front wall.
        camera: Some(DefaultCamera { eye: [2.0, 1.45, 0.25], target: [2.0, 1.05, 5.0], fov_deg: 62.0 }),
        picture_camera: None,
        build: mirror_room,
    },
    BuiltIn {
        name: "open-blocks",
        syntax: "open-blocks",
        description: "three diffuse blocks on a 4 x 4 floor under a small 0.5 x 0.5 area light, open to a black background (adaptive sampling's open scene)",
        camera: Some(DefaultCamera { eye: [0.0, 2.3, 4.2], target: [0.0, 0.3, 0.0], fov_deg: 40.0 }),
        picture_camera: None,
        build: open_blocks,
    },
    BuiltIn {
        name: "open-sphere",
        syntax: "open-sphere[:L]",
        description: "a diffuse geodesic sphere (level L in 1..=6, default 4: 1,280 triangles) and a cube on a 4 x 4 floor under a small area light, open to a black background",
        camera: Some(DefaultCamera { eye: [0.0, 2.3, 4.2], target: [0.0, 0.3, 0.0], fov_deg: 40.0 }),
        picture_camera: None,
        build: open_sphere,
    },
    BuiltIn {
        name: "chairs-room",
        syntax: "chairs-room",
        description: "the table with four chairs (wood) in a 5 x 2.6 x 5 m white room lit by a 1 x 1 m ceiling light (after Part III Fig. 18a; radiosity test scene)",
        // A corner of the room, inside, looking down at the table.
        camera: Some(DefaultCamera { eye: [2.3, 1.8, 2.3], target: [0.0, 0.45, 0.0], fov_deg: 55.0 }),
        picture_camera: None,
        build: chairs_room,
    },
];

/// A built-in scene by spec, e.g. `"torus:32,16"` (see [`BUILT_IN`]).
///
/// Every parameter is checked against its range and the scene's size
/// against [`Limits`] before anything is built.
///
/// # Errors
/// [`SceneError::UnknownScene`], [`SceneError::BadParameter`],
/// [`SceneError::ExtraParameters`], [`SceneError::TooLarge`], or
/// [`SceneError::Geometry`] if the built scene does not validate.
pub fn built_in(spec: &str) -> Result<Scene, SceneError> {
    let mut parts = spec.split(':');
    let name = parts.next().unwrap_or_default();
    let Some(entry) = BUILT_IN.iter().find(|b| b.name == name) else {
        let known = BUILT_IN.iter().map(|b| b.syntax).collect::<Vec<_>>().join(", ");
        return Err(SceneError::UnknownScene { name: name.to_string(), known });
    };
    let args = Args { spec, name, syntax: entry.syntax, parts: parts.collect() };
    let scene = (entry.build)(&args)?;
    scene.validate()?;
    Ok(scene)
}

/// The `:`-separated parameters of one spec.
struct Args<'a> {
    spec: &'a str,
    name: &'a str,
    syntax: &'static str,
    parts: Vec<&'a str>,
}

impl Args<'_> {
    fn at_most(&self, n: usize) -> Result<(), SceneError> {
        if self.parts.len() > n {
            return Err(SceneError::ExtraParameters { spec: self.spec.to_string(), syntax: self.syntax });
        }
        Ok(())
    }

    fn bad(&self, name: &'static str, range: &RangeInclusive<u32>, got: &str) -> SceneError {
        SceneError::BadParameter {
            spec: self.spec.to_string(),
            name,
            expected: format!("an integer in {}..={}", range.start(), range.end()),
            got: got.to_string(),
        }
    }

    fn int(&self, s: &str, name: &'static str, range: &RangeInclusive<u32>) -> Result<u32, SceneError> {
        s.parse::<u32>().ok().filter(|v| range.contains(v)).ok_or_else(|| self.bad(name, range, s))
    }

    /// Parameter `i` (after the name), or `default` when absent.
    fn one(&self, i: usize, name: &'static str, range: RangeInclusive<u32>, default: u32) -> Result<u32, SceneError> {
        self.parts.get(i).map_or(Ok(default), |s| self.int(s, name, &range))
    }

    /// Parameter `i` as `A,B`, or `default` when absent.
    fn pair(
        &self,
        i: usize,
        names: (&'static str, &'static str),
        range: RangeInclusive<u32>,
        default: (u32, u32),
    ) -> Result<(u32, u32), SceneError> {
        let Some(p) = self.parts.get(i) else { return Ok(default) };
        let mut it = p.split(',');
        let (a, b) = (it.next().unwrap_or_default(), it.next());
        let Some(b) = b else { return Err(self.bad(names.1, &range, "")) };
        if it.next().is_some() {
            return Err(SceneError::ExtraParameters { spec: self.spec.to_string(), syntax: self.syntax });
        }
        Ok((self.int(a, names.0, &range)?, self.int(b, names.1, &range)?))
    }

    fn check(&self, triangles: u64, patches: u64) -> Result<(), SceneError> {
        Limits::check(self.spec, triangles, patches)
    }
}

fn cube_enclosure(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(1)?;
    let n = a.one(0, "N", 1..=1000, 10)?;
    let n2 = u64::from(n) * u64::from(n);
    a.check(12 * n2, 6 * n2)?;
    let mut s = Scene::new(a.spec);
    s.add_box("cube", DVec3::ZERO, DVec3::ONE, n, true, 0);
    Ok(s)
}

fn solid(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(0)?;
    let mut s = Scene::new(a.spec);
    for (i, face) in crate::solids::faces(a.name).iter().enumerate() {
        // Seen from inside: reverse the outward winding.
        let inward: Vec<DVec3> = face.iter().rev().copied().collect();
        s.add_polygon(format!("face {i}"), &inward, 0);
    }
    Ok(s)
}

fn sphere(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(1)?;
    let (b, sct) = a.pair(0, ("B", "S"), 1..=4096, (8, 16))?;
    a.check(0, u64::from(b) * u64::from(sct))?;
    let cells = SphereCells { radius: 1.0, bands: b, sectors: sct };
    Ok(Scene {
        name: a.spec.into(),
        patches: sphere_patches(cells),
        materials: vec![Material::default()],
        sphere: Some(cells),
        ..Scene::default()
    })
}

fn cornell_box(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(0)?;
    Ok(crate::solids::cornell_box())
}

fn geosphere(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(1)?;
    let l = a.one(0, "L", 1..=9, 2)?;
    let t = 20 * 4u64.pow(l - 1);
    a.check(t, t)?;
    Ok(crate::meshes::geosphere(a.spec, l - 1))
}

fn torus(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(1)?;
    let (u, v) = a.pair(0, ("U", "V"), 3..=4096, (48, 24))?;
    let q = u64::from(u) * u64::from(v);
    a.check(2 * q, q)?;
    Ok(crate::meshes::torus(a.spec, 1.0, 0.4, u, v))
}

fn table_chairs(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(1)?;
    let n = a.one(0, "N", 1..=256, 2)?;
    let cells = crate::meshes::TABLE_CHAIRS_BOXES * 6 * u64::from(n) * u64::from(n);
    a.check(2 * cells, cells)?;
    Ok(crate::meshes::table_with_chairs(a.spec, n))
}

fn cubes_room(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(3)?;
    let mut clustered = None;
    let mut seed = None;
    for p in a.parts.iter().skip(1) {
        match *p {
            "clustered" | "random" if clustered.is_none() => clustered = Some(*p == "clustered"),
            s if seed.is_none() && s.parse::<u64>().is_ok() => seed = s.parse().ok(),
            s => {
                return Err(SceneError::BadParameter {
                    spec: a.spec.to_string(),
                    name: "clustered|random|SEED",
                    expected: "'clustered' or 'random' and a seed in 0..=2^64-1, each at most once".into(),
                    got: s.to_string(),
                });
            }
        }
    }
    let clustered = clustered.unwrap_or(false);
    let max = if clustered { crate::solids::MAX_CLUSTERED } else { crate::solids::MAX_RANDOM };
    let k = a.one(0, "K", 1..=max, 27)?;
    a.check(12 * (100 + u64::from(k)), 6 * (100 + u64::from(k)))?;
    crate::solids::cubes_room(a.spec, k, clustered, seed.unwrap_or(1))
}

fn mirror_room(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(1)?;
    let l = a.one(0, "L", 1..=6, 5)?;
    Ok(crate::render::room::mirror_room(a.spec, l - 1))
}

fn open_blocks(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(0)?;
    Ok(crate::render::open::open_blocks(a.spec))
}

fn open_sphere(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(1)?;
    let l = a.one(0, "L", 1..=6, 4)?;
    Ok(crate::render::open::open_sphere(a.spec, l - 1))
}

fn chairs_room(a: &Args) -> Result<Scene, SceneError> {
    a.at_most(0)?;
    let mut s = crate::meshes::table_with_chairs(a.spec, 1);
    s.materials = vec![
        Material { name: "wood".into(), reflectance: [0.55, 0.40, 0.25], ..Material::default() },
        Material { name: "wall".into(), reflectance: [0.75, 0.75, 0.72], ..Material::default() },
        Material { name: "light".into(), reflectance: [0.8; 3], emittance: [12.0, 11.0, 9.0], mirror: false },
    ];
    s.add_box("room", DVec3::new(-2.5, 0.0, -2.5), DVec3::new(2.5, 2.6, 2.5), 1, true, 1);
    let y = 2.59;
    // Facing down: counter-clockwise seen from below.
    let light =
        [DVec3::new(-0.5, y, -0.5), DVec3::new(0.5, y, -0.5), DVec3::new(0.5, y, 0.5), DVec3::new(-0.5, y, 0.5)];
    s.add_polygon("light", &light, 2);
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_registry_camera_is_valid_and_subdivided_scenes_keep_theirs() {
        for b in BUILT_IN {
            for c in [b.camera, b.picture_camera].into_iter().flatten() {
                assert!(
                    Camera::look_at(DVec3::from(c.eye), DVec3::from(c.target), DVec3::Y, c.fov_deg).is_ok(),
                    "{}",
                    b.name
                );
            }
        }
        let mut s = built_in("chairs-room").unwrap();
        s.name = "chairs-room/2".into();
        let want = BuiltIn::of("chairs-room").and_then(|b| b.camera).map(|c| c.camera());
        assert_eq!(scene_camera(&s, |b| b.camera), want);
        let cornell = built_in("cornell-box").unwrap();
        let (render, pictures) =
            (scene_camera(&cornell, |b| b.camera), scene_camera(&cornell, BuiltIn::radiosity_camera));
        assert!(render.unwrap().eye.z > 0.0 && pictures.unwrap().eye.z < 0.0, "inside the box; outside its front wall");
        assert_eq!(scene_camera(&built_in("cube").unwrap(), |b| b.camera), None);
    }
}
