//! `visualization_msgs`: Marker and MarkerArray (Humble and later layout, with the texture
//! and mesh_file fields).

use super::{ColorRGBA, Duration, Header, Point, Pose, Vector3};
use serde::{Deserialize, Serialize};

/// `sensor_msgs/msg/CompressedImage`: an image in a compressed file format (here only as
/// [`Marker::texture`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Acquisition time and the camera's optical frame.
    pub header: Header,
    /// Compression format, e.g. `jpeg` or `png`.
    pub format: String,
    /// The compressed image file's bytes.
    #[serde(with = "crate::octets")]
    pub data: Vec<u8>,
}
super::ros_message!(CompressedImage, "sensor_msgs", "CompressedImage");

/// `visualization_msgs/msg/UVCoordinate`: a position on a 2D texture, as fractions of its size.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UVCoordinate {
    /// Fraction of the texture's width, 0..=1.
    pub u: f32,
    /// Fraction of the texture's height, 0..=1.
    pub v: f32,
}
super::ros_message!(UVCoordinate, "visualization_msgs", "UVCoordinate");

/// `visualization_msgs/msg/MeshFile`: a mesh file sent inside a message.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshFile {
    /// File name; its extension tells the loader the mesh format.
    pub filename: String,
    /// The mesh file's bytes.
    #[serde(with = "crate::octets")]
    pub data: Vec<u8>,
}
super::ros_message!(MeshFile, "visualization_msgs", "MeshFile");

/// `visualization_msgs/msg/Marker`: one shape for RViz (or Foxglove) to add, change or delete.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    /// Time of the marker and the frame `pose` is in.
    pub header: Header,
    /// Namespace; with `id`, names the marker for later changes and deletion.
    pub ns: String,
    /// Identifier within `ns`.
    pub id: i32,
    /// Shape, one of the type constants ([`Marker::ARROW`] …); `type` in the `.msg`.
    pub type_: i32,
    /// [`Marker::ADD`], [`Marker::DELETE`] or [`Marker::DELETEALL`].
    pub action: i32,
    /// Pose of the marker in `header.frame_id`; `points` are relative to it.
    pub pose: Pose,
    /// Size along the marker's x, y, z, metres (1, 1, 1 is the default); what each means
    /// depends on `type_`.
    pub scale: Vector3,
    /// Colour of the whole marker.
    pub color: ColorRGBA,
    /// Time before the marker is deleted automatically; zero keeps it until deleted.
    pub lifetime: Duration,
    /// Whether the marker is re-transformed into its frame at every update, following the
    /// frame as it moves.
    pub frame_locked: bool,
    /// Vertices or positions for the list, strip and point types, metres in the marker's
    /// frame (`pose`).
    pub points: Vec<Point>,
    /// Per-point colours for those types: empty, or one per entry of `points`.
    pub colors: Vec<ColorRGBA>,
    /// Texture URI (resource_retriever), or `embedded://name` to use `texture`.
    pub texture_resource: String,
    /// Texture image, used when `texture_resource` is `embedded://…`.
    pub texture: CompressedImage,
    /// Texture coordinates of the vertices, each in [0, 1].
    pub uv_coordinates: Vec<UVCoordinate>,
    /// Text of a [`Marker::TEXT_VIEW_FACING`] marker.
    pub text: String,
    /// Mesh URI of a [`Marker::MESH_RESOURCE`] marker (resource_retriever), or
    /// `embedded://name` to use `mesh_file`.
    pub mesh_resource: String,
    /// Mesh sent in the message, used when `mesh_resource` is `embedded://…`.
    pub mesh_file: MeshFile,
    /// Whether to draw the mesh with the materials its file defines.
    pub mesh_use_embedded_materials: bool,
}
super::ros_message!(Marker, "visualization_msgs", "Marker");

impl Marker {
    /// `type_`: an arrow along the x axis of `pose`, or from `points[0]` to `points[1]`.
    pub const ARROW: i32 = 0;
    /// `type_`: a box of size `scale`.
    pub const CUBE: i32 = 1;
    /// `type_`: an ellipsoid of diameters `scale`.
    pub const SPHERE: i32 = 2;
    /// `type_`: a cylinder along z, diameters `scale.x` and `scale.y`, height `scale.z`.
    pub const CYLINDER: i32 = 3;
    /// `type_`: a polyline through `points`, `scale.x` wide.
    pub const LINE_STRIP: i32 = 4;
    /// `type_`: a segment per pair of `points`, `scale.x` wide.
    pub const LINE_LIST: i32 = 5;
    /// `type_`: a box of size `scale` at each of `points`.
    pub const CUBE_LIST: i32 = 6;
    /// `type_`: a sphere of size `scale` at each of `points`.
    pub const SPHERE_LIST: i32 = 7;
    /// `type_`: a square at each of `points`, `scale.x` wide and `scale.y` high.
    pub const POINTS: i32 = 8;
    /// `type_`: `text` facing the viewer, `scale.z` the height of an uppercase "A".
    pub const TEXT_VIEW_FACING: i32 = 9;
    /// `type_`: the mesh named by `mesh_resource`.
    pub const MESH_RESOURCE: i32 = 10;
    /// `type_`: a triangle per three `points`.
    pub const TRIANGLE_LIST: i32 = 11;

    /// `action`: add the marker, or replace the one with the same `ns` and `id`.
    pub const ADD: i32 = 0;
    /// `action`: delete the marker with this `ns` and `id`.
    pub const DELETE: i32 = 2;
    /// `action`: delete every marker (only those of `ns`, if it is set).
    pub const DELETEALL: i32 = 3;
}

/// `visualization_msgs/msg/MarkerArray`: several markers in one message.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MarkerArray {
    /// The markers, processed in order.
    pub markers: Vec<Marker>,
}
super::ros_message!(MarkerArray, "visualization_msgs", "MarkerArray");
