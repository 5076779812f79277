// Instance segmentation of one depth view of a bin of unknown objects, with no object model:
// the points above the bin's floor and inside its walls, cut into supervoxels (PCL 1.13's; docs/
// design/point-cloud-library.md), which are joined into object segments by a learned score of how
// each two meet - LCCP's convexity criterion among what it reads (Stein, Schoeler, Papon,
// Woergoetter, "Object Partitioning using Local Convexity", CVPR 2014), the step and the line of
// no depth between them in the image - greedily, within what an object can measure.
//   depth -> the pixels' points in the world -> those inside the bin (its footprint less the walls'
//   margin, above the floor's noise, below the tallest object) -> supervoxels (voxels grown from
//   seeds on a grid, by distance and normals) -> each connection between neighbouring supervoxels
//   scored (the log-odds of one object, a logistic model fitted on generated piles), and the pair
//   of segments whose connections sum highest joined, while a sum is above 0 and the two together
//   fit an object's size (greedy additive edge contraction) -> a segment whose pixels fall apart
//   in the image (the camera measured no depth between them) cut into its pieces -> neighbouring
//   segments joined while their points together fit what an object can measure seen from above
//   -> a small elongated segment left (a piece of an object) joined to a neighbour it fits with in
//   some turn -> a segment whose outline narrows to a waist between two deep concavities cut
//   there, unless the depth is smooth across the cut -> segments, each the pixels of its points.
// SegmentationOptions::merge = kConvexity joins the supervoxels by LCCP instead (the default before
// 2026-12-08): neighbouring supervoxels joined where the surface between them is convex or smooth
// -> LCCP's segments joined where the connections between them are mostly convex ones only its
// sanity criterion refused -> a segment larger than any object cut again at a tighter concavity.
// Reads only the frame's depth and its camera (the extrinsics as calibrated) and the bin's known
// geometry. Every PCL call runs on this thread; the same image gives the same segments.
// SegmentationOptions::method picks instead region growing or clustering with normals, the
// alternatives LCCP was measured against (docs/measurements/perception.md).
#pragma once
#include <array>
#include <vector>

#include "core/camera.h"
#include "core/geometry.h"

namespace mm {

/// How the points are cut into segments: supervoxels joined (by a learned score, or by LCCP: merge;
/// the default), or, measured against LCCP (docs/measurements/perception.md), region growing or
/// clustering by distance and normals.
enum class SegmentationMethod { kLccp, kRegionGrowing, kNormalClusters };

/// How kLccp joins neighbouring supervoxels into segments: by a learned score of each connection,
/// greedily within the objects' size (the default), or by LCCP's convexity alone.
enum class SupervoxelMerge { kLearned, kConvexity };

struct SegmentationOptions {
  SegmentationMethod method = SegmentationMethod::kLccp;
  // Where to look: the bin's floor frame (z up), its footprint's half sizes, and how high above
  // its floor (the tallest object).
  Pose T_world_region = Pose::Identity();
  Vec3 region_half = Vec3::Zero();  ///< x, y [m]
  double region_height = 0.15;      ///< [m] above the floor
  double floor_margin = 0.006;      ///< [m] points this close to the floor's plane are the floor's (its noise)
  double wall_margin = 0.004;       ///< [m] points this close to the footprint's edge, or beyond, are the walls'
  // Supervoxels and LCCP (PCL's names; LCCP's for merge kConvexity).
  double voxel = 0.004;                ///< [m] the voxel
  double seed = 0.025;                 ///< [m] the supervoxels' seed spacing
  double normal_importance = 4.0;      ///< against spatial importance 1 (colour: none)
  double concavity_tolerance = 25.0;   ///< [deg] a connection this far concave is still convex (the noise's normals)
  double smoothness = 0.0;             ///< LCCP's smoothness threshold (0: no smoothness check)
  int k_factor = 0;                    ///< extended convexity: common neighbours convex to both (0: none)
  int min_supervoxels = 3;             ///< a segment of at most this many supervoxels joins its largest neighbour (LCCP's rule)
  /// kLearned: each connection between neighbouring supervoxels scored by a logistic model of how
  /// the two meet (kConnectionWeights over the measures supervoxelGraph gives: LCCP's angles among
  /// them, the step and the line of no depth between them in the image), the log-odds that they are
  /// one object's; then greedy additive edge contraction (Keuper et al., "Efficient decomposition
  /// of image and mesh graphs by lifted multicuts", ICCV 2015): the pair of neighbouring segments
  /// whose connections' scores sum highest joins, their connections to others summed, until no sum
  /// is above 0 - but a pair whose points together fit max_object_length by max_object_width in no
  /// turn (seen from above, 1-degree turns) is never joined (where those are 0, any pair may).
  /// kConvexity: LCCP's segments (its convexity criterion, concavity_tolerance, the sanity
  /// criterion), then the joins and cuts of sanity_join and recut_tolerance.
  SupervoxelMerge merge = SupervoxelMerge::kLearned;
  /// [log-odds] added to every connection's score (kLearned): below 0 joins fewer.
  double merge_bias = -2.0;
  /// Two of LCCP's segments join where the connections between them that only LCCP's sanity
  /// criterion refused are at least one, and at least this many times the concave ones (0: never;
  /// merge kConvexity only).
  double sanity_join = 2.0;
  /// [m] What an object of the bin can measure seen from above: the principal extents of its
  /// points over the floor, along (length) and across (width). Two neighbouring segments (through
  /// their supervoxels, or their instance masks touching) whose points together fit in these are
  /// joined, the pair of the shortest union first, until no pair fits (0: no such join). From the
  /// objects' own limit (objects.generated's max_extent, both ways: a ring is as wide as it is
  /// long), as the crop's height is from the tallest object.
  double max_object_length = 0, max_object_width = 0;
  /// [deg] An LCCP segment larger than an object can be (max_object_length by max_object_width;
  /// none when those are 0) is cut again at connections concave by more than this (0: never);
  /// pieces of at most min_supervoxels join their largest neighbour within it. After the join of
  /// faces seen edge on, before LCCP's rule for small segments and the join by size (merge
  /// kConvexity only).
  double recut_tolerance = 12.0;
  /// A segment whose own pixels fall apart in the image (4-connected: the camera measured no depth
  /// between them, as along the edge where two objects touch) is cut into its pieces of at least
  /// min_pixels, the smaller staying with the largest; before the join by size, which puts one
  /// object's pieces back. Only with the objects' size limits (max_object_length, max_object_width).
  bool split_unconnected = true;
  /// A segment of fewer pixels than this that the join by size left, elongated seen from above
  /// (its principal extents at least `crumb_aspect` to one: an arc of a ring, a piece of a bar, not
  /// a small solid's compact top), is a piece of an object: it joins a neighbour when their points
  /// together fit max_object_length by max_object_width in some turn (the smallest such box over
  /// 1-degree turns: the principal extents overstate an L's or an arc's), the pair of the
  /// shortest union first. After the join by size, before the cut at a waist; only with the
  /// objects' size limits; 0: never.
  int crumb_pixels = 100;
  double crumb_aspect = 1.6;
  /// [m] A crumb joins only a neighbour whose top (its highest point above the floor) is within
  /// this of the crumb's: a piece of one object lies at about its neighbour piece's height (a
  /// ring's arc beside the other), a small part of another object seen beside it mostly not (one
  /// lying lower against its side, or on it); 0: any neighbour.
  double crumb_top_step = 0.008;
  /// [m] Two neighbouring segments the joins above left apart, whose border in the image is
  /// smooth: of the pixel pairs where their pixels touch (4-neighbours), at least `smooth_pairs`
  /// and at least `smooth_share` of them differ in depth by at most this. One surface that LCCP
  /// cut where it turns concave (a bar at its bend) is smooth across the cut; two objects side by
  /// side are mostly parted by a step in depth or a line of no depth. They join when their points
  /// together fit max_object_length by max_object_width in some turn (as the crumbs'), the pair of
  /// the shortest union first. After the join of crumbs, before the cut at a waist; only with the
  /// objects' size limits; 0: never.
  double smooth_step = 0.004;
  double smooth_share = 0.3;
  int smooth_pairs = 4;
  /// [m] A segment whose outline seen in the image (its instance mask) has two concavities at
  /// least this deep (OpenCV's convexity defects, converted to pixels at the segment's depth) is
  /// cut along the line between their deepest points, when that line is short: under
  /// `waist_ratio` times the square root of the smaller part's pixels (two touching solids, each
  /// convex from above, meet at such a waist), and each part has min_pixels. The shortest such
  /// cut first; a part is not cut again. Only with the objects' size limits (max_object_length,
  /// max_object_width), after the join by size; 0: never.
  double waist_depth = 0.01;
  double waist_ratio = 0.6;
  /// A segment whose mask fills less than this share of the pixels its outline encloses is not
  /// cut at a waist: a speckled mask (a hollow object's wall seen through the sensor's dropout,
  /// the floor's depth among its pixels) has a ragged outline whose notches are as deep as a
  /// waist, where two solids side by side fill theirs (0: every segment is read).
  double waist_fill = 0.98;
  /// A waist whose pixel pairs across the cut are smooth in depth as the smooth join reads a
  /// border (smooth_step, smooth_share, smooth_pairs; not read when smooth_step is 0) is not cut: one
  /// surface narrowing (a bent bar at its bend), where two objects side by side are parted by a
  /// step in depth or a line of no depth.
  bool waist_smooth = true;
  /// [m] Two objects side by side whose pixels the camera parts by a line of no depth (where their
  /// tops meet) all but for a narrow bridge stay one segment, and the join by size keeps two small
  /// ones together. A segment whose own pixels, eroded by half this width (a 4-neighbour diamond,
  /// in pixels at the segment's depth, at least one), fall apart into cores of at least
  /// `bridge_core_area` each is cut: each pixel to the nearest core through the segment's pixels.
  /// Only where the line is of no depth: the pixels of no depth near two of the parts (within
  /// twice the erosion) at least `bridge_gap` times the pixels where the parts touch (a neck of
  /// one object, a blend's parts, is mostly outline). After the cut at a waist; only with the
  /// objects' size limits; 0: never.
  double bridge_width = 0.005;
  double bridge_core_area = 4e-4;  ///< [m^2] seen from above at the segment's depth (about 60 pixels at 640 x 480)
  double bridge_gap = 6.0;
  // Region growing (PCL's RegionGrowing; its names) and clustering with normals (PCL's
  // ConditionalEuclideanClustering), each at the best of the settings measured.
  int grow_neighbours = 32;            ///< region growing: the nearest points a normal is fitted to, and its neighbours
  double grow_angle = 12.0;            ///< [deg] region growing: neighbours join while their normals are this close
  double grow_curvature = 1.0;         ///< region growing: a point of less curvature grows the region on (PCL's curvature is at most 1/3: 1, no test)
  int cluster_neighbours = 64;         ///< clustering: the nearest points a normal is fitted to
  double cluster_angle = 25.0;         ///< [deg] clustering: neighbours join while their normals are this close ...
  double cluster_tolerance = 0.0055;   ///< [m] ... and they are this close
  int min_pixels = 30;                 ///< segments of fewer pixels, ...
  /// [m^2] ... or whose pixels cover less than this at their points' depths (a pixel's footprint
  /// across the camera's axis, z/fx by z/fy), are no object (Segmentation::small) ... Over the
  /// bin seen from 1.25 m, 34 pixels at 640 x 480 and 136 at 1280 x 960 (where min_pixels alone
  /// is 2.2 and 0.55 cm^2): the same size at any resolution.
  double min_area = 2.5e-4;
  int min_obstacle_pixels = 8;         ///< ... and of fewer than this, or whose top is ...
  double min_obstacle_height = 0.012;  ///< [m] ... lower than this above the floor, the depth's noise (dropped)
};

/// One segment: its pixels (v * width + u, ascending) and its points in the world.
struct Segment {
  std::vector<int> pixels;
  std::vector<Vec3> points;
  Vec3 centroid = Vec3::Zero();  ///< [m] world
  double top = 0;                ///< [m] its highest point above the floor
};

struct Segmentation {
  std::vector<Segment> segments;  ///< by their first pixel
  std::vector<Segment> small;     ///< too small to be an object, seen all the same (obstacles), by their first pixel
  int points = 0;                 ///< the pixels inside the bin, above its floor
  int supervoxels = 0;            ///< the supervoxels' count (0 with the other methods)
  double seconds = 0;             ///< wall clock (benchmarks print it; nothing decides by it)
};

/// The segments of `frame`'s depth inside the region.
Segmentation segmentDepth(const Frame& frame, const SegmentationOptions& o);

/// What the learned merge (SupervoxelMerge::kLearned) reads of a connection between two
/// neighbouring supervoxels; kConnectionWeights weighs them (the first is 1, the constant's).
constexpr int kConnectionFeatures = 25;
using ConnectionFeatures = std::array<double, kConnectionFeatures>;
extern const ConnectionFeatures kConnectionWeights;

/// The supervoxels segmentDepth (method kLccp) cuts `frame`'s depth into, each by its pixels
/// (ascending), and the connections between neighbouring ones with what the learned merge reads
/// of them. For fitting kConnectionWeights (labels from the renderer's, which segmentDepth never
/// reads; tests/perception/pile_segmentation_test.cc) and measuring it.
struct SupervoxelGraph {
  struct Connection {
    int a = 0, b = 0;  ///< supervoxels, a < b
    ConnectionFeatures features{};
  };
  std::vector<std::vector<int>> pixels;
  std::vector<Connection> connections;  ///< by (a, b)
};
SupervoxelGraph supervoxelGraph(const Frame& frame, const SegmentationOptions& o);

/// An oracle's segments: the renderer's per-object labels (Frame::segmentation) cut the same points
/// of the region (its depth, as segmentDepth takes them) into one segment per object, with
/// segmentDepth's rules for pieces too small to be objects. No real camera has these labels: it
/// measures what segmentDepth loses, apart from what grasping loses.
Segmentation segmentLabels(const Frame& frame, const SegmentationOptions& o);

/// Each segment's instance mask (pixels v * width + u, ascending), as an instance segmentation is
/// scored (BOP's visible masks hold an object's pixels whatever the sensor measured there): the
/// segment's own pixels, and the pixels of no depth about it (a stereo camera's dropout at depth
/// edges, where a thin wall can lose most of its pixels). In each of `passes` rounds, a pixel of no
/// depth goes to the segment that most of its 3 x 3 neighbours belong to, unless as many or more of
/// them are pixels of depth in no segment (the floor, a patch too small to be an object); a tie
/// between segments goes to the first. Reads only the depth; the segments' points are not changed
/// (the masks are what segmentation is scored by; segmentDepth's join by size reads them only to
/// find which segments touch).
std::vector<std::vector<int>> segmentMasks(const Frame& frame, const std::vector<Segment>& segments, int passes = 3);

/// What the robot knows of a segment's object, having no model of it: the columns under what the
/// camera saw of it (what is under a seen surface is unknown, so taken as occupied), as an
/// occupancy map of the bin would hold it. In the region's frame (z up from its floor), turned to
/// the principal axes of the segment's points seen from above, the points are binned into cells
/// (`cell` along the major axis, 5/6 of it across); neighbouring cells along the major axis join
/// while the run's tops stay within `step` of each other; each run is one column, a box from the
/// floor to its highest point, as wide and long as the run's points reach (not the whole cells:
/// the cells of two touching segments overlap, their points do not). The object (shape kMesh, the
/// columns its convex pieces) has its frame at the middle of the columns' bounding box, z up; its
/// mass is unknown (0).
ObjectState segmentObject(const Segment& s, const Pose& T_world_region, double cell = 0.012, double step = 0.01);

}  // namespace mm
