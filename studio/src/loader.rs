//! Turns incoming files into scene parts, with `fitslam_core::io` doing all the parsing.
//!
//! | file | becomes |
//! |---|---|
//! | `.yaml`/`.yml` map_server description | a map, once its image is there (same drop or pick, or next to it natively) |
//! | `.yaml`/`.yml`/`.toml` parameter file | the parameters |
//! | `.png`/`.pgm` alone | a map at the current resolution, origin (0, 0), map_server's default thresholds |
//! | `.pcd`/`.ply`/`.csv`/`.las`/`.laz` | a landmark set, or a traversability map computed from it (the user says which) |
//! | `.mcap` | a recorded mission (rosbag2), opened at its first decision instant |
//!
//! Every failure is a message naming the file; nothing here panics on input.

use crate::files::{IncomingFile, Intent, base_name};
use crate::recording::Recording;
use crate::scene::{Landmarks, MapKind, MapLayers};
use fitslam_core::Params;
use fitslam_core::io::{self, MapError, MapThresholds, MapYaml};
use fitslam_core::traversability::TraversabilityMap;

/// What a file turned into.
#[derive(Debug)]
pub enum Loaded {
    Map(MapLayers),
    Landmarks(Landmarks),
    Params(Box<Params>),
    Recording(Box<Recording>),
    /// A map YAML whose image has not arrived yet (the web cannot read a file's neighbours).
    WaitingForImage {
        yaml_name: String,
        image: String,
    },
    /// A point cloud dropped without saying what it is: the user is asked.
    AskCloudUse(IncomingFile),
}

fn extension(name: &str) -> String {
    base_name(name).rsplit_once('.').map(|(_, e)| e.to_ascii_lowercase()).unwrap_or_default()
}

fn is_cloud(ext: &str) -> bool {
    matches!(ext, "pcd" | "ply" | "csv" | "las" | "laz")
}

fn is_image(ext: &str) -> bool {
    matches!(ext, "png" | "pgm")
}

/// What one batch leaves for the next, so a map's YAML and its image pair up in either order
/// even when they arrive separately (two drops, two picks).
#[derive(Debug, Default)]
pub struct Pairing {
    /// Map YAMLs still waiting for their image: (YAML name, YAML bytes, image base name).
    waiting: Vec<(String, Vec<u8>, String)>,
    /// The last image loaded as a bare map: (base name, name, bytes). Only the last is kept.
    last_image: Option<(String, String, Vec<u8>)>,
}

/// Loads a batch of files (one drop or one pick). A map YAML is paired with an image whose base
/// name matches its `image:` key: first from the batch, then (natively) the file next to it,
/// then the last bare image of an earlier batch; otherwise it waits in `pairing` for a later
/// batch. `params` gives the resolution of bare images and the traversability parameters for
/// clouds.
pub fn load_batch(files: Vec<IncomingFile>, pairing: &mut Pairing, params: &Params) -> Vec<Result<Loaded, String>> {
    let mut out = Vec::new();
    // Images of this batch, by base name, so YAMLs can claim them.
    let mut images: Vec<(String, String, Vec<u8>)> = Vec::new();
    let mut others = Vec::new();
    for f in files {
        match f.bytes {
            Err(e) => out.push(Err(format!("{}: cannot read: {e}", f.name))),
            Ok(bytes) if is_image(&extension(&f.name)) => images.push((base_name(&f.name).to_string(), f.name, bytes)),
            Ok(bytes) => others.push(IncomingFile { name: f.name, bytes: Ok(bytes), intent: f.intent }),
        }
    }
    for f in others {
        let Ok(bytes) = f.bytes else { continue };
        let ext = extension(&f.name);
        match ext.as_str() {
            "yaml" | "yml" => match MapYaml::parse(&bytes, &f.name) {
                Ok(yaml) => {
                    let wanted = base_name(&yaml.image).to_string();
                    if let Some(k) = images.iter().position(|(b, _, _)| *b == wanted) {
                        let (_, image_name, image_bytes) = images.remove(k);
                        out.push(map_from_yaml(&bytes, &f.name, &image_bytes, &image_name));
                    } else if let Some((image_name, image_bytes)) = crate::files::read_sibling(&f.name, &yaml.image) {
                        out.push(match image_bytes {
                            Ok(b) => map_from_yaml(&bytes, &f.name, &b, &image_name),
                            Err(e) => Err(format!("{}: its image {}: {e}", f.name, yaml.image)),
                        });
                    } else if let Some((_, image_name, image_bytes)) = pairing.last_image.take_if(|(b, _, _)| *b == wanted) {
                        out.push(map_from_yaml(&bytes, &f.name, &image_bytes, &image_name));
                    } else {
                        pairing.waiting.retain(|(n, _, _)| *n != f.name);
                        pairing.waiting.push((f.name.clone(), bytes, wanted.clone()));
                        out.push(Ok(Loaded::WaitingForImage { yaml_name: f.name, image: wanted }));
                    }
                }
                Err(map_err) => {
                    if f.intent == Intent::Map {
                        out.push(Err(map_err.to_string()));
                    } else {
                        out.push(params_or_error(&bytes, &f.name, Some(&map_err)));
                    }
                }
            },
            "toml" => out.push(params_or_error(&bytes, &f.name, None)),
            "mcap" => out.push(Recording::open(&bytes, &f.name).map(|r| Loaded::Recording(Box::new(r)))),
            e if is_cloud(e) => out.push(load_cloud(f.name, bytes, f.intent, params)),
            _ => out.push(Err(format!(
                "{}: unsupported file type (maps: .yaml + .pgm/.png, .png; landmarks or terrain: .pcd .ply .csv .las; parameters: .yaml .toml; recordings: .mcap)",
                f.name
            ))),
        }
    }
    // Images left: a waiting YAML's, or bare maps.
    for (base, name, bytes) in images {
        if let Some(k) = pairing.waiting.iter().position(|(_, _, img)| *img == base) {
            let (yaml_name, yaml_bytes, _) = pairing.waiting.remove(k);
            out.push(map_from_yaml(&yaml_bytes, &yaml_name, &bytes, &name));
        } else {
            out.push(bare_image_map(&bytes, &name, params.grid.resolution_m));
            pairing.last_image = Some((base, name, bytes));
        }
    }
    out
}

fn map_from_yaml(yaml: &[u8], yaml_name: &str, image: &[u8], image_name: &str) -> Result<Loaded, String> {
    let grid = io::load_map(yaml, yaml_name, image, image_name).map_err(|e| e.to_string())?;
    let mut map = MapLayers::from_occupancy(&grid, base_name(yaml_name));
    map.kind = MapKind::Occupancy;
    Ok(Loaded::Map(map))
}

fn bare_image_map(bytes: &[u8], name: &str, resolution_m: f64) -> Result<Loaded, String> {
    let grid = io::load_map_image(bytes, name, resolution_m, [0.0, 0.0], &MapThresholds::default()).map_err(|e| e.to_string())?;
    Ok(Loaded::Map(MapLayers::from_occupancy(&grid, base_name(name))))
}

fn params_or_error(bytes: &[u8], name: &str, map_err: Option<&MapError>) -> Result<Loaded, String> {
    match Params::from_bytes(bytes, name) {
        Ok(p) => Ok(Loaded::Params(Box::new(p.into_inner()))),
        Err(pe) => Err(match map_err {
            // A YAML that is neither: say both, the map reason first (maps are the usual case).
            Some(me) => format!("{me}; not a parameter file either: {pe}"),
            None => pe.to_string(),
        }),
    }
}

fn load_cloud(name: String, bytes: Vec<u8>, intent: Intent, params: &Params) -> Result<Loaded, String> {
    match intent {
        Intent::Landmarks => {
            let cloud = io::load_cloud(&bytes, &name).map_err(|e| e.to_string())?;
            if cloud.is_empty() {
                return Err(format!("{name}: no landmarks in the file"));
            }
            Ok(Loaded::Landmarks(Landmarks { cloud, source: base_name(&name).to_string() }))
        }
        Intent::TerrainCloud => {
            let cloud = io::load_cloud(&bytes, &name).map_err(|e| e.to_string())?;
            let map = TraversabilityMap::from_cloud(&cloud, params).map_err(|e| format!("{name}: {e}"))?;
            Ok(Loaded::Map(MapLayers::from_terrain(map, &params.traversability, base_name(&name))))
        }
        Intent::Any | Intent::Map | Intent::Params | Intent::Recording => {
            Ok(Loaded::AskCloudUse(IncomingFile { name, bytes: Ok(bytes), intent }))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(name: &str, bytes: &[u8]) -> IncomingFile {
        IncomingFile { name: name.into(), bytes: Ok(bytes.to_vec()), intent: Intent::Any }
    }

    /// A 2 × 1 binary PGM: a black (lethal) and a white (free) pixel.
    const PGM: &[u8] = b"P5\n2 1\n255\n\x00\xff";

    #[test]
    fn yaml_and_image_pair_within_a_batch_by_base_name() {
        let yaml = b"image: sub/tiny.pgm\nresolution: 0.5\norigin: [1.0, 2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
        let mut pending = Pairing::default();
        let out = load_batch(vec![file("tiny.pgm", PGM), file("tiny.yaml", yaml)], &mut pending, &Params::default());
        assert_eq!(out.len(), 1);
        let Ok(Loaded::Map(m)) = &out[0] else { panic!("{out:?}") };
        let g = m.geometry();
        assert_eq!((g.width, g.height, g.resolution_m, g.origin_x_m, g.origin_y_m), (2, 1, 0.5, 1.0, 2.0));
        assert_eq!(m.score.data, vec![0.0, 1.0]);
        assert!(pending.waiting.is_empty() && pending.last_image.is_none());
    }

    #[test]
    fn yaml_and_image_pair_across_batches_in_either_order() {
        let yaml: &[u8] =
            b"image: tiny.pgm\nresolution: 0.5\norigin: [1.0, 2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
        let params = Params::default();
        for image_first in [true, false] {
            let mut pairing = Pairing::default();
            let (a, b) = if image_first {
                (file("tiny.pgm", PGM), file("tiny.yaml", yaml))
            } else {
                (file("tiny.yaml", yaml), file("tiny.pgm", PGM))
            };
            let first = load_batch(vec![a], &mut pairing, &params);
            if image_first {
                let Ok(Loaded::Map(m)) = &first[0] else { panic!("{first:?}") };
                assert_eq!(m.geometry().resolution_m, params.grid.resolution_m, "a bare image first");
            } else {
                assert!(matches!(&first[0], Ok(Loaded::WaitingForImage { image, .. }) if image == "tiny.pgm"), "{first:?}");
            }
            let second = load_batch(vec![b], &mut pairing, &params);
            let Ok(Loaded::Map(m)) = &second[0] else { panic!("{second:?}") };
            let g = m.geometry();
            assert_eq!((g.resolution_m, g.origin_x_m, g.origin_y_m), (0.5, 1.0, 2.0), "image first: {image_first}");
            assert!(pairing.waiting.is_empty() && pairing.last_image.is_none());
        }
    }

    #[test]
    fn a_lone_image_is_a_map_at_the_current_resolution() {
        let mut params = Params::default();
        params.grid.resolution_m = 0.1;
        let out = load_batch(vec![file("x.pgm", PGM)], &mut Pairing::default(), &params);
        let Ok(Loaded::Map(m)) = &out[0] else { panic!("{out:?}") };
        assert_eq!(m.geometry().resolution_m, 0.1);
        assert_eq!(m.source, "x.pgm");
    }

    #[test]
    fn parameter_files_load_and_bad_ones_name_the_file() {
        let out = load_batch(vec![file("p.toml", b"[u1]\nalpha = 0.7\n")], &mut Pairing::default(), &Params::default());
        let Ok(Loaded::Params(p)) = &out[0] else { panic!("{out:?}") };
        assert_eq!(p.u1.alpha, 0.7);
        let out = load_batch(vec![file("p.yaml", b"u1:\n  alpha: 0.2\n")], &mut Pairing::default(), &Params::default());
        assert!(matches!(&out[0], Ok(Loaded::Params(p)) if p.u1.alpha == 0.2), "{out:?}");
        let out = load_batch(vec![file("q.yaml", b"u1:\n  alpah: 0.2\n")], &mut Pairing::default(), &Params::default());
        let Err(e) = &out[0] else { panic!("{out:?}") };
        assert!(e.contains("q.yaml") && e.contains("alpah"), "{e}");
    }

    #[test]
    fn clouds_without_intent_ask_and_with_intent_load() {
        let csv = b"x,y,z\n1,2,3\n4,5,6\n";
        let out = load_batch(vec![file("l.csv", csv)], &mut Pairing::default(), &Params::default());
        assert!(matches!(&out[0], Ok(Loaded::AskCloudUse(f)) if f.name == "l.csv"), "{out:?}");
        let f = IncomingFile { name: "l.csv".into(), bytes: Ok(csv.to_vec()), intent: Intent::Landmarks };
        let out = load_batch(vec![f], &mut Pairing::default(), &Params::default());
        assert!(matches!(&out[0], Ok(Loaded::Landmarks(l)) if l.cloud.len() == 2), "{out:?}");
    }

    #[test]
    fn a_terrain_cloud_becomes_a_score_map() {
        // A flat 1 m × 1 m floor sampled every 2 cm: every cell with enough points is free.
        let mut csv = String::from("x,y,z\n");
        for i in 0..50 {
            for j in 0..50 {
                csv += &format!("{},{},0\n", i as f64 * 0.02, j as f64 * 0.02);
            }
        }
        let f = IncomingFile { name: "floor.csv".into(), bytes: Ok(csv.into_bytes()), intent: Intent::TerrainCloud };
        let out = load_batch(vec![f], &mut Pairing::default(), &Params::default());
        let Ok(Loaded::Map(m)) = &out[0] else { panic!("{out:?}") };
        assert_eq!(m.kind, MapKind::Traversability);
        assert!(m.known_cells() > 0);
        assert!(m.score.data.iter().filter(|s| !s.is_nan()).all(|&s| s >= 0.5));
    }
}
