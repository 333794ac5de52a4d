//! [`GraphSlam`]'s factor graph as a g2o file, in the order the mission built it.

use super::GraphSlam;
use crate::slam::backend::SlamBackend;
use crate::slam::g2o::{G2oEdge, G2oFile, G2oVertex};
use crate::slam::lie::Se3;
use crate::slam::values::Variable;

impl GraphSlam {
    /// The graph as a g2o file in *replay order*: per keyframe, the landmarks it saw first, then
    /// its pose, so that [`G2oReplay`](crate::slam::G2oReplay) makes one update per keyframe with the factors
    /// this solver's update had. Vertices at the current estimate; the odometry as
    /// `EDGE_SE3:QUAT`, the observations as `EDGE_SE3_TRACKXYZ` through sensor offset 0 (the
    /// identity). The anchor and the gravity factors have no g2o form and the robust kernel is
    /// dropped: returns the file and how many factors it leaves out. O(variables + factors).
    pub(super) fn g2o_file(&self) -> (G2oFile, usize) {
        let estimate = self.estimate();
        let n = estimate.len();
        // Variables from one keyframe's to the next are that keyframe's new landmarks.
        let mut file_id = vec![0u64; n];
        let mut next = 0u64;
        for (k, &pose) in self.keyframes.iter().enumerate() {
            let end = self.keyframes.get(k + 1).map_or(n, |v| v.0);
            for id in &mut file_id[pose.0 + 1..end] {
                *id = next;
                next += 1;
            }
            file_id[pose.0] = next;
            next += 1;
        }
        let mut file = G2oFile::default();
        file.offsets.insert(0, Se3::identity());
        let mut by_file_id: Vec<(u64, Variable)> = estimate.iter().map(|(v, var)| (file_id[v.0], *var)).collect();
        by_file_id.sort_unstable_by_key(|&(id, _)| id);
        file.vertices = by_file_id
            .into_iter()
            .filter_map(|(id, var)| match var {
                Variable::Se3(pose) => Some(G2oVertex::Se3 { id, pose }),
                Variable::Point3(point) => Some(G2oVertex::Point3 { id, point }),
                _ => None,
            })
            .collect();
        let factors = self.graph().factors();
        file.edges = factors.iter().filter_map(|f| f.measurement()).map(|m| G2oEdge::of_measurement(&m, |v| file_id[v.0])).collect();
        let left_out = factors.len() - file.edges.len();
        (file, left_out)
    }
}
