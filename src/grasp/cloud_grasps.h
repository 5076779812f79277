// Model-free 6-DoF grasps of a parallel gripper from one depth view, with no object model: the
// geometry of GPD (ten Pas, Gualtieri, Saenko, Platt, "Grasp Pose Detection in Point Clouds",
// IJRR 2017), scored by hand-written rules where GPD scores with a network.
//   depth -> the points inside the region (the bin with its walls) in the world, thinned to one
//   per voxel -> normals (the smallest principal axis of the neighbours, turned to the camera)
//   -> seeds drawn on the points above the floor
//   -> per seed a frame from the normals around it (the eigenvectors of sum n n^T: the largest is
//      the surface's normal, the smallest the axis it curves least about)
//   -> hands: the approach along -normal turned about that axis in steps (a flat face, whose axis is
//      any, also turned about its normal), each also rolled about its approach to close along the
//      level direction across it (the hand's wide body then stays off the floor; for an approach
//      near straight down, one more heading); those tilted more than max_tilt from straight down
//      dropped
//   -> per hand the fingers centred on the points between them, opened by a margin wider than
//      those points, and the hand pushed as deep as it goes with the fingers' and the palm's
//      straight approach clear of every observed point (the walls, the neighbours), the fingers and
//      the hand above the floor (the bin's known plane: its points are noise around it), and the
//      fingers out of the space the camera cannot see (behind an observed surface)
//   -> kept when enough contacts on each side have normals inside the friction cone about the
//      closing direction (antipodal), the fingers mostly out of unseen space, and (given the
//      boxes the planner will check against) out of every box but the held object's; scored by
//      those contacts, the points between the pads, the tilt and the clearance beside the
//      fingers; near-duplicates suppressed, best first.
#pragma once
#include <vector>

#include "core/camera.h"
#include "core/geometry.h"
#include "core/rng.h"
#include "grasp/grasp.h"

namespace mm {

/// Points in the world with outward normals (turned towards the camera that saw them).
struct PointCloud {
  std::vector<Vec3> points, normals;
};

/// A box the motion planner will check the hand against: a part of a perceived object (`owner`,
/// its index in CloudGraspOptions::objects) or of nothing perceived (-1: a patch no segment
/// explains). Half sizes.
struct OwnedBox {
  Pose T_world = Pose::Identity();
  Vec3 half = Vec3::Zero();
  int owner = -1;
};

struct CloudGraspOptions {
  // Where to look: the bin's floor frame, its footprint's half sizes, and how far beyond it and
  // how high above its floor the points are kept (the walls and the tallest object).
  Pose T_world_region = Pose::Identity();
  Vec3 region_half = Vec3::Zero();  ///< x, y [m]
  double region_margin = 0.03;      ///< [m] beyond the footprint (the walls' tops)
  double region_height = 0.15;      ///< [m] above the floor
  double floor_margin = 0.01;       ///< [m] points this close to the floor (its noise: 2 mm sigma at 1.2 m) ...
  double floor_normal = 0.5;        ///< [rad] ... and whose normal is within this of the floor's
  double floor_noise = 0.005;        ///< [m] points this close to the floor are its, whatever their normals (the depth's noise), and left out of the hands' checks for its plane
  /// The sensor's depth noise (sigma = depth_sigma_k z^2, z the depth along the camera's axis) [1/m]:
  /// a floor point facing up within floor_sigmas of it (and floor_margin) is the floor's plane too.
  double depth_sigma_k = 0.0;
  double floor_sigmas = 3.0;
  double floor_clearance = 0.002;    ///< [m] the fingers and the hand (padded) at least this far above the floor's plane
  double wall_margin = 0.004;       ///< [m] points this close to the footprint's edge, or beyond, are the walls'
                                    ///< (floor and walls: obstacles, never seeds, never between the pads)
  double voxel = 0.003;             ///< [m] one point per voxel
  double normal_radius = 0.008;     ///< [m] neighbours of a normal's fit
  double frame_radius = 0.012;      ///< [m] normals of a seed's frame
  int seeds = 400;
  int approach_steps = 8;           ///< turns about the frame's axis from -90 degrees in steps of 180 / approach_steps (8: to +67.5)
  double level_turn = 0.17;         ///< [rad] a hand whose closing axis is more than this from the level direction across its approach is tried along that too
  double max_tilt = 0.9;            ///< [rad] the approach from straight down
  /// [rad] A view that gives no candidate is searched again (more seeds from the stream), each
  /// approach within this of straight down taken straight down with its closing axis level, every
  /// seed's hands also turned by 45, 90 and 135 degrees about its normal (as a flat face's always
  /// are), and a hand whose fingertips reach the floor kept with `floor_contacts` cells (0: no
  /// second look).
  double snap_down = 0.0;
  /// A view whose best candidate scores below this is looked at again too (with snap_down), and the
  /// two looks' candidates ranked together (0: only a view with none).
  double weak_score = 0.0;
  double depth_step = 0.004;        ///< [m] the push along the approach
  double min_bite = 0.012;          ///< [m] the fingertips at least this far past the seed (GPD's init_bite: 0.01)
  double finger_margin = 0.012;     ///< [m] each finger opens this far beyond the points between them
  double cone = 0.35;               ///< [rad] a contact face's normal within this of the closing axis (GPD: 20 degrees)
  int min_contacts = 4;             ///< cells of the pad (of 3 x 6) the object fills, on each side
  int floor_contacts = 4;           ///< ... or, in the second look (snap_down), this many where the fingertips are at the floor
  int min_points = 20;              ///< points between the pads
  double unknown_margin = 0.006;    ///< [m] a finger point this far behind the observed surface is in unseen space
  double max_unknown = 0.3;         ///< share of the fingers' points allowed in unseen space
  double approach_clear = 0.1;      ///< [m] the straight approach checked for points, back from the grasp
  double padding = 0.0;             ///< [m] the fingers (but their inner faces) and the hand inflated by this (the planner's padding)
  double hand_length = 0.06;        ///< [m] the hand body behind its front, checked
  int max_candidates = 40;
  double nms_distance = 0.01;       ///< [m] a candidate this close to a better one ...
  double nms_angle = 0.35;          ///< [rad] ... and turned less than this from it is dropped
  // The gripper in the TCP frame (z along the approach, the fingers closing along y), as GraspOptions;
  // the defaults are the Panda's hand as trials derive it (cloudGraspOptionsFor).
  double hand_opening = 0.08;       ///< [m] the full stroke
  double finger_thickness = 0.018;  ///< [m] along y
  double pad_half_width = 0.0105;   ///< [m] along x
  double pad_z_min = -0.045, pad_z_max = 0.009;  ///< [m] the pads along z (the tip: max)
  double hand_back = 0.0414;        ///< [m] the hand body's front behind the TCP
  double hand_half_thickness = 0.042, hand_half_width = 0.102;  ///< [m] the hand body along x, y
  // What the planner knows of the bin's contents (none: the points alone). A hand whose open
  // fingers, at the grasp or up to 6 cm back along its approach, enter one of `boxes` (padded)
  // that is not of the object between its pads (objectBetweenPads over `objects`) is dropped:
  // the planner would refuse it, and the points leave room there that the boxes fill (a box
  // reaches past a round outline's points, and down under what the camera saw).
  std::vector<ObjectState> objects;
  std::vector<OwnedBox> boxes;
  // Score weights.
  double contact_weight = 1.0, closure_weight = 1.0, points_weight = 0.5, tilt_weight = 0.5, clearance_weight = 10.0;
};

/// The detector's options for a gripper as grasp/ knows it (its stroke, pads, hand body, fingers).
CloudGraspOptions cloudGraspOptionsFor(const GraspOptions& hand);

/// The points of `frame`'s depth inside the region, one per voxel (their mean), with normals;
/// in the order of the pixels, so the same image gives the same cloud.
PointCloud cloudFromDepth(const Frame& frame, const CloudGraspOptions& o);

struct CloudGraspResult {
  /// The points the hands were sought on, and the normals the detector fitted: a normal is fitted
  /// only when read (most of the floor's never are), the others are zero. cloudFromDepth gives all.
  PointCloud cloud;
  std::vector<GraspCandidate> candidates;  ///< best first; type kCloud
  int seeds = 0, hands = 0;                ///< seeds drawn, hands evaluated (a seed drawn again counts its hands again)
  /// Of the seeds drawn, those drawn again in the same look (the draws are with replacement): the
  /// seed's hands are not evaluated again (the same hand twice is one candidate); their tallies
  /// below are counted again.
  int seeds_repeated = 0;
  /// Why hands were dropped: tilted beyond max_tilt; the pads closing on the floor or a wall, the
  /// fingers' or the hand's approach through points, too wide, the fingers or the hand too near the
  /// floor (before any depth was right); too few points between the pads, not antipodal (at every
  /// depth); the fingers in unseen space. (A point in the way of both the fingers and the hand
  /// counts as whichever the scan meets first.)
  /// And, with CloudGraspOptions::boxes, the fingers in a neighbour's box.
  int tilted = 0, on_cell = 0, fingers_blocked = 0, hand_blocked = 0, too_wide = 0, too_low = 0, sparse = 0, not_antipodal = 0, unseen = 0,
      neighbour = 0;
  struct {
    /// Wall-clock seconds (benchmarks print them; nothing decides by them): the points in the
    /// region, one per voxel; the hands, with the normals they read.
    double cloud = 0, hands = 0;
  } seconds;
};

/// Grasp candidates from the depth of `frame` (its camera's extrinsics trusted). `preferred_x` the
/// world direction the TCP's x should point along (of the two hands turned half a turn about the
/// approach, which are one grasp, the one nearer it); `rng` draws the seeds.
CloudGraspResult cloudGrasps(const Frame& frame, const CloudGraspOptions& o, const Vec3& preferred_x, Rng& rng);

/// Whether a hand of axes `R` (x across the pads, y closing, z the approach) about a seed
/// `seed_height` above the floor (whose up direction is `up`) has, at the first depth it is pushed
/// to, a finger's or the hand body's corner (padded) under the floor's clearance whatever run of
/// points its pads close on (a run about the seed no wider than the stroke): a bound cloudGrasps
/// uses to drop such a hand unread.
bool handTooLowAtFirstDepth(const Mat3& R, double seed_height, const Vec3& up, const CloudGraspOptions& o);

/// The object of `objects` the pads of `g` close on (their perceived shapes and poses: a mesh
/// object's pieces one by one): its index, -1 when they close on none, -2 when on two or more.
int objectBetweenPads(const GraspCandidate& g, const std::vector<ObjectState>& objects, const CloudGraspOptions& o);

}  // namespace mm
