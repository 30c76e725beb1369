//! Building the Embree scene: one triangle geometry over the shared arrays, or, with cut-outs, an
//! opaque geometry and a filtered one over the same vertices; the instances of prototypes (see
//! `instances`); then the commit.

use super::cutout::Cutouts;
use super::device::{AccelError, check, device};
use super::instances::{InstanceXfm, attach_instances, prototype_scenes};
use super::triangles::attach;
use super::{Accel, SharedArray};
use embree_sys as sys;
use glam::Vec3;
use std::ffi::c_void;
use std::ops::Range;

impl Accel {
    /// Builds and commits a scene of `triangles` over `positions`. Embree reads both arrays in
    /// place, for as long as the scene exists: the `Accel` keeps a reference to each. Triangles
    /// must index valid vertices (the scene loader guarantees it and drops degenerate ones).
    pub fn new(
        positions: &SharedArray<Vec3>,
        triangles: &SharedArray<[u32; 3]>,
    ) -> Result<Accel, AccelError> {
        Accel::with_cutouts(positions, triangles, &[])
    }

    /// As [`Accel::new`], with the triangles whose indices are in `cutout` (strictly increasing)
    /// in a geometry of their own that has Embree's intersection and occlusion filters, so that
    /// rays pass through them where [`Accel::set_cut_test`] says; the other triangles' geometry
    /// has no filter and costs what it did. Hits and point queries report indices into
    /// `triangles` either way. With cut-outs, each geometry reads an index array of its own.
    pub fn with_cutouts(
        positions: &SharedArray<Vec3>,
        triangles: &SharedArray<[u32; 3]>,
        cutout: &[u32],
    ) -> Result<Accel, AccelError> {
        Accel::with_instances(positions, triangles, triangles.len(), cutout, &[], &[])
    }

    /// As [`Accel::with_cutouts`] for the first `world` triangles (in world space; `cutout` among
    /// them), and the instances `instances` of the prototypes whose triangles are the `prototypes`
    /// ranges of `triangles` (in prototype space, after the first `world`). A hit on an instance
    /// reports the instance's index and the triangle's index in `triangles`
    /// ([`RawHit`](super::RawHit)).
    pub fn with_instances(
        positions: &SharedArray<Vec3>,
        triangles: &SharedArray<[u32; 3]>,
        world: usize,
        cutout: &[u32],
        prototypes: &[Range<u32>],
        instances: &[InstanceXfm],
    ) -> Result<Accel, AccelError> {
        if triangles.len() >= u32::MAX as usize
            || positions.len() >= u32::MAX as usize
            || instances.len() >= (u32::MAX - super::instances::FIRST_INSTANCE_GEOM) as usize
        {
            return Err(AccelError::TooLarge(triangles.len(), positions.len()));
        }
        debug_assert!(world <= triangles.len());
        debug_assert!(
            prototypes
                .iter()
                .all(|r| r.start as usize >= world && r.end as usize <= triangles.len())
        );
        debug_assert!(
            instances
                .iter()
                .all(|i| (i.prototype as usize) < prototypes.len())
        );
        debug_assert!(
            triangles
                .iter()
                .flatten()
                .all(|&i| (i as usize) < positions.len())
        );
        debug_assert!(cutout.windows(2).all(|w| w[0] < w[1]));
        debug_assert!(cutout.iter().all(|&i| (i as usize) < world));
        let dev = device()?;
        // SAFETY: dev is a live device; the scene is released by Drop (or below on error).
        let scene = unsafe { sys::rtcNewScene(dev) };
        check(dev, "rtcNewScene")?;
        let mut accel = Accel {
            scene,
            shared_positions: positions.clone(),
            shared_triangles: triangles.clone(),
            cutouts: None,
            prototypes: Vec::new(),
            instance_first: instances
                .iter()
                .map(|i| prototypes[i.prototype as usize].start)
                .collect(),
        };
        // SAFETY: scene is live. Robust mode avoids optimisations that can let rays slip through
        // shared edges and vertices, which the FTPD walks cross often.
        unsafe {
            sys::rtcSetSceneFlags(scene, sys::RTCSceneFlags_RTC_SCENE_FLAG_ROBUST);
            sys::rtcSetSceneBuildQuality(scene, sys::RTCBuildQuality_RTC_BUILD_QUALITY_HIGH);
        }
        if cutout.is_empty() {
            if world > 0 {
                attach(
                    dev,
                    scene,
                    0,
                    &accel.shared_positions,
                    &accel.shared_triangles,
                    0..world as u32,
                    None,
                )?;
            }
        } else {
            let mut is_cut = vec![false; world];
            for &i in cutout {
                is_cut[i as usize] = true;
            }
            let opaque: Vec<u32> = (0..world as u32).filter(|&i| !is_cut[i as usize]).collect();
            let pick = |ids: &[u32]| {
                SharedArray::new(ids.iter().map(|&i| triangles[i as usize]).collect())
            };
            let cuts = Box::new(Cutouts {
                indices: [pick(&opaque), pick(cutout)],
                opaque,
                cut: cutout.to_vec(),
                test: None,
            });
            let user = &*cuts as *const Cutouts as *mut c_void;
            let [opaque_tris, cut_tris] = cuts.indices.clone();
            accel.cutouts = Some(cuts);
            if !opaque_tris.is_empty() {
                let all = 0..opaque_tris.len() as u32;
                attach(
                    dev,
                    scene,
                    0,
                    &accel.shared_positions,
                    &opaque_tris,
                    all,
                    None,
                )?;
            }
            let all = 0..cut_tris.len() as u32;
            attach(
                dev,
                scene,
                1,
                &accel.shared_positions,
                &cut_tris,
                all,
                Some(user),
            )?;
        }
        if !instances.is_empty() {
            accel.prototypes = prototype_scenes(
                dev,
                &accel.shared_positions,
                &accel.shared_triangles,
                prototypes,
            )?;
            attach_instances(dev, scene, &accel.prototypes, instances)?;
        }
        // SAFETY: scene is live and fully described.
        unsafe { sys::rtcCommitScene(scene) };
        check(dev, "rtcCommitScene")?;
        Ok(accel)
    }
}
