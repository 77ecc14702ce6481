#pragma once
// The authority on objects (thesis 3.1 and 3.4): consolidates the trackers' estimates of one
// frame, segments the scene, updates every model, creates objects from unexplained clusters and
// retires objects that lost support.

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <vector>

#include "mfot/carry_monitor.hpp"
#include "mfot/companion_motion.hpp"
#include "mfot/discovery_confirmation.hpp"
#include "mfot/individuation.hpp"
#include "mfot/join_split.hpp"
#include "mfot/label_propagation.hpp"
#include "mfot/likelihood.hpp"
#include "mfot/model_contact.hpp"
#include "mfot/model_registration.hpp"
#include "mfot/model_updater.hpp"
#include "mfot/object_discovery.hpp"
#include "mfot/occlusion.hpp"
#include "mfot/part_finder.hpp"
#include "mfot/part_refit.hpp"
#include "mfot/reidentification.hpp"
#include "mfot/segmentation.hpp"
#include "mfot/smr_feature.hpp"
#include "mfot/tracked_object.hpp"
#include "mfot/types.hpp"

namespace mfot {

// Member defaults: the thesis's values, for library users and unit tests; the services and
// mfot-inprocess fill every field from configs/default.yaml (the shipped defaults).
struct ObjectManagerOptions {
  SegmentationOptions segmentation;     // tau (3.23)
  ModelUpdateOptions model_update;      // alpha (3.4); seed is the base, each object adds its id
  NewObjectOptions new_objects;         // when an unexplained cluster becomes an object
  SupportLossOptions support;           // when an object without support is retired
  SmrOptions smr;                       // colour feature of model points
  std::size_t min_object_points = 50;   // >= 1: smaller clusters never become objects
  std::size_t max_model_points = 1500;  // >= min_object_points: a new model is subsampled to this
                                        // size, a growing one thins out evenly to stay within it
  // Unexplained points of a cluster that also holds segmented points take the label of the
  // nearest segmented point reachable through unexplained points in steps of at most this
  // (metres; the preprocess cluster tolerance): the rest of an arm entering the view, what tau
  // missed of an object. 0 disables it (only tau's segmentation labels points).
  float propagation_radius = 0.015f;
  // ... but only in a cluster at least this share of whose points are segmented. [0, 1]; 0 = any.
  float propagation_min_seed_share = 0.f;
  // An object younger than this (frames) also grows its model by the points it gains so:
  // objects entering the view (a hand and its arm reaching in from the border) are seen a part
  // at a time. 0 disables growth.
  int growth_frames = 300;
  // A retired object is remembered this many frames (0: never): a new object whose colour
  // distribution matches a remembered one's (its last model's or its first, partial view's) takes its id back (a hand
  // leaving the view and reaching in again, an object lost and found again), so ids stay stable for controllers.
  int reidentify_frames = 900;
  // Least Bhattacharyya coefficient of the two SMR colour histograms for a match, (0, 1]. A re-identified object's
  // remembered model is registered on its new points (ModelRegistration): when that succeeds the object keeps its
  // frame (its pose goes on where it left off) and its whole model, the new points added; otherwise it starts from
  // a new model and frame under its old id.
  float reidentify_similarity = 0.9f;
  // A young object (growth_frames) that took no remembered id when it was born is matched again each frame its model
  // grows, against the objects retired by its birth: the first piece of a returning object (a corner showing in the
  // hand that brings it back) may show too little for its colours to match, its grown model matches. On a match it
  // takes the remembered id back as at birth (retired under its own id, created under the remembered one, its
  // points registered) ...
  // ... but only once its model holds at least this share of the remembered model's points: a piece in the hand
  // that brings the object back registers the remembered model on too little of it (a few degrees of a turn fit
  // it as well), and the merged model and the pose carry that error until the object is seen whole. [0, 1]; 0 =
  // as soon as its colours match.
  float reidentify_grown_min_share = 0.f;
  // A live object not seen in the frame (its tracker holds it, or it lacks support but is not retired yet) is a new
  // object's candidate as a retired one is (RetiredObjects::match_unseen), when the new object's model radius is at
  // most this times its model's: it is that object found elsewhere (it moved while hidden), so the new object takes
  // its id and model as from a retired one (it is retired and created under that id in the same frame), instead of
  // a second id born before the first retires. 0 = off (the thesis); else [1, 10].
  float reidentify_unseen_radius_ratio = 0.f;
  ModelRegistrationOptions registration;
  // An object lacking support whose model, at its pose, is at least this share occluded by
  // nearer scene points is hidden (a hand in front of it), not gone: such frames do not count
  // towards its retirement. [0, 1]; 0 = every frame counts (the thesis has no retirement rule).
  float hidden_occluded_share = 0.0f;
  // Unexplained points of a persisting cluster that lie mostly (half or more) inside a held object's bounding
  // sphere (its model's bounding box at its pose, half the diagonal grown by this, metres) are no new object: they
  // are the held object's own points, its estimate stale while its tracker holds it (a box turned inside the hand
  // whose claims cover it). [0, 0.5]; 0 = off (the thesis holds nothing).
  float held_birth_margin = 0.0f;
  // A persisting cluster confirmed within entering_frames of the birth of an object that itself entered the view
  // (born after the first frame), whose model lies within entering_distance of its unexplained points, is a part of
  // that object entering with it, in a cluster of its own (a gripper's finger behind its palm, an arm beyond a
  // hand): the object grows by it instead of a new object being born. Frames [0, 1000], 0 = off (the thesis makes
  // each cluster an object); metres (0, 0.1].
  int entering_frames = 0;
  float entering_distance = 0.03f;
  OcclusionOptions occlusion;
  // How a born cluster becomes objects: the services make the ObjectDiscovery of this with
  // make_object_discovery and hand it to the manager (the manager itself only validates it).
  DiscoveryOptions discovery;
  JoinSplitOptions join_split;  // step 7: RigidPartJoin and PartSplit
  // Hidden objects carried by the object they moved with (CarryMonitor; frames 0 = off, the thesis).
  CarryOptions carry;
  // Each seen object's companion: the touching object whose last step its filter may follow
  // (companion_motion.hpp; contact_distance 0 = off, the thesis).
  CompanionOptions companion;
  // Grown parts re-fitted on the first view where a frame shows both well (PartRefit; the thesis keeps no parts).
  PartRefitOptions refit;
  void validate() const;
};

// What a tracker reports for one object and frame.
struct ObjectEstimate {
  Pose pose;               // object -> camera
  float confidence = 0.f;  // 0..1
  bool held = false;       // the tracker held its filter: nothing of the object to score (hidden)
};

struct ManagedObject {
  std::int32_t id = 0;
  ObjectModel model;                         // object frame
  Pose pose;                                 // latest estimate, object -> camera
  PoseVector velocity = PoseVector::Zero();  // last pose change per frame: dx, dy, dz, droll, dpitch, dyaw
  float confidence = 0.f;
  bool stale = false;        // no estimate arrived for the latest frame
  bool held = false;         // its tracker held it in the latest frame (ObjectEstimate::held)
  std::int32_t version = 0;  // incremented on every model change
  // The model's parts, each placed with one frame's pose, as the end index of each (ascending, the last
  // one the model's size): part 0 the view that set the object's frame, one part per growth, join or
  // registration since (PartRefit). One part when the model update mixes points (alpha > 0).
  std::vector<std::uint32_t> part_ends;
  std::size_t support = 0;         // scene points segmented to it in the latest frame
  std::int64_t created_frame = 0;  // frames_processed() when it was created
  // Hidden this frame and carried by this object (its motion moved the pose; CarryMonitor); 0 = not
  // carried. Its tracker moves its filter to the pose.
  std::int32_t carried_by = 0;
  // A touching object that moved in its latest step (CompanionOptions), 0 = none, and the increment
  // (as velocity) that moving rigidly with it would give this object: its filter predicts a share of
  // its particles by it in the next frame.
  std::int32_t companion = 0;
  PoseVector companion_motion = PoseVector::Zero();
};

struct ObjectManagerFrame {
  std::vector<std::int32_t> labels;                           // per scene point: object id, 0 = none
  std::vector<std::int32_t> created;                          // ids created this frame (ascending)
  std::vector<std::int32_t> registered;                       // of those, re-identified ones that kept their frame
  std::vector<std::int32_t> retired;                          // ids retired this frame (joined ones too)
  std::vector<std::pair<std::int32_t, std::int32_t>> joined;  // (kept, joined into it) this frame
  std::vector<std::pair<std::int32_t, std::int32_t>> split;   // (split, new object from its part)
  // (young, remembered) this frame: a young object took a remembered id back once grown; young is in retired,
  // remembered in created.
  std::vector<std::pair<std::int32_t, std::int32_t>> reidentified;
  // (object, sibling) this frame: confirm_discovery gave points of the object to the sibling whose part they lie in.
  std::vector<std::pair<std::int32_t, std::int32_t>> regrouped;
  // Carried objects that took a birth's points this frame (seen again away from their carried pose; no id created).
  std::vector<std::int32_t> found_carried;
};

// Thesis 3.1 / 3.4 per frame, after the trackers' estimates (3.3) of that frame. Steps:
//   1. take each object's estimate (an object without one keeps its pose and is marked stale);
//      with carry.frames > 0, a hidden object that moved with a touching object before it was hidden
//      follows that object's motion instead (CarryMonitor), and with carry.seen_through_share > 0
//      one gripped while hidden whose place the scene shows empty (OcclusionTest's seen_through_share,
//      on this frame's scene) is retired in step 4 (re-identified when it shows again); with
//      companion.contact_distance > 0, each object's companion is chosen (companion_motion.hpp);
//   2. segment the scene: nearest model point within tau over all objects (3.22, 3.23);
//   3. update every non-stale object's model with alpha (3.4); re-fit the grown parts of every object
//      seen this frame on the first view (PartRefit);
//   4. retire objects whose support stayed below the minimum for several frames; frames in
//      which an object is hidden (its model mostly occluded by nearer scene points, or carried
//      while its tracker held it) do not count; and those gripped away (step 1);
//   5. unexplained points of clusters that hold segmented points (standing on the table or not: a
//      gripper's arm raised beyond the table's far edge is still the gripper's) take the label of the nearest
//      one reachable through unexplained points (breadth first, in waves); young objects grow
//      their models by the points they gain (thinned evenly over the whole model when it
//      would exceed max_model_points);
//   6. create objects from clusters standing on the table that no object explains: at the first frame every one,
//      later only clusters persisting for a few frames (non-contact case, after [KLK14]) and not
//      lying mostly inside a held object (held_birth_margin: its own points); a cluster found within
//      entering_frames of the birth of an object that entered the view, near its model, grows that object
//      instead (a part entering with it in a cluster of its own); with a
//      discovery (object_discovery.hpp) such a cluster's unexplained points are first split into
//      their locally convex parts, each an object (touching and stacked objects apart), the parts'
//      boundaries then drawn point by point by colour (part_boundary.hpp); a new
//      model is the points in a frame at their centroid, axis-aligned with the camera. A new
//      object whose SMR colour histogram matches a recently retired object's takes that id
//      back, and its remembered model is registered on the new points so that it keeps its object
//      frame (when that fails its model and frame are new: the pose jumps once); a new
//      object whose histogram matches an object carried this frame (step 1) whose model registers on its
//      points is that object seen again, its carried pose a guess too far off for tau: it takes the points,
//      the registered pose and the merged model, and no object is born; a young object grown in step 5
//      that matched none at birth is matched again so, once its model holds reidentify_grown_min_share
//      of the remembered model's points; with reidentify_unseen_radius_ratio > 0, a new object that matches
//      no retired or carried one is matched so against the live objects not seen this frame (held, or
//      lacking support): the one it matches is retired and its id taken back at once;
//   7. join objects born together that moved as one rigid body (RigidPartJoin) and seen objects that occupy one
//      space (OverlapJoin), split objects whose parts
//      moved apart (PartSplit; both join_split.hpp), and, over the first confirm_frames frames of the objects born
//      from one cluster, discover their points again together: once that disagreed with them in confirm_votes
//      frames, its parts become the objects, and two of them that it never told apart are one
//      (DiscoveryConfirmation).
// Per live object the manager publishes a ManagedObject (objects()) and keeps one TrackedObject (tracked_object.hpp);
// retired objects are remembered by RetiredObjects (reidentification.hpp), hidden objects' watches by CarryMonitor,
// pairs' watches by RigidPartJoin and DiscoveryConfirmation; the contact tests of steps 1 and 7 are ModelContact's.
// Deterministic: object ids increase from 1, every draw comes from per-object seeded updaters.
class ObjectManager {
 public:
  // discovery: splits born clusters into objects (nullptr: a cluster is one object, the thesis).
  explicit ObjectManager(const ObjectManagerOptions& options = {},
                         std::unique_ptr<ObjectDiscovery> discovery = nullptr);
  // discoveries: one per thread that splits a frame's clusters side by side (PartFinder; none: a cluster is one
  // object); the output is the same for every count.
  ObjectManager(const ObjectManagerOptions& options, std::vector<std::unique_ptr<ObjectDiscovery>> discoveries);
  ObjectManager(const ObjectManager&) = delete;
  ObjectManager& operator=(const ObjectManager&) = delete;

  const ObjectManagerOptions& options() const { return options_; }

  // The image the next scenes come from (nullopt: unknown): the seen-through test of carry step 1 counts
  // no model point outside it (OcclusionTest::set_view).
  void set_view(const std::optional<ViewBounds>& view) { view_ = view; }

  // scene: the preprocessed scene (camera frame); cluster_of_point: its Euclidean clusters
  // (-1 = none), of which [0, standing_clusters) stand on the table and may become objects, the others only carry
  // the labels of objects tracked into them (SceneCloud::standing_clusters); estimates: by object id, for this frame
  // (a non-finite one counts as missing). Throws std::invalid_argument for mismatched sizes, a non-finite scene point
  // or a negative standing_clusters.
  const ObjectManagerFrame& process(const ColoredCloud& scene, std::span<const std::int32_t> cluster_of_point,
                                    int standing_clusters, const std::map<std::int32_t, ObjectEstimate>& estimates);
  // The same with every cluster standing (a scene without a table prism).
  const ObjectManagerFrame& process(const ColoredCloud& scene, std::span<const std::int32_t> cluster_of_point,
                                    const std::map<std::int32_t, ObjectEstimate>& estimates) {
    return process(scene, cluster_of_point, std::numeric_limits<int>::max(), estimates);
  }

  const std::map<std::int32_t, ManagedObject>& objects() const { return objects_; }
  const ObjectManagerFrame& last_frame() const { return frame_; }
  // What the other objects claim near object `id` (for its tracker's exclude_claimed_radius): their
  // model points at their latest poses (camera frame) that lie inside id's model bounding box at
  // its latest pose, grown by margin (the tracker's hypothesis margin plus the claim radius), in
  // order of object id and model point. out is cleared first; none for an unknown id.
  void claimed_points(std::int32_t id, float margin, std::vector<Eigen::Vector3f>& out) const;
  std::int64_t frames_processed() const { return frames_; }
  // Ids up to `id` are in use elsewhere (objects the trackers still hold when a merger restarts):
  // new objects get larger ones. Ids outside [1, kMaxObjectId] are ignored (false): no received
  // value can push the id counter towards overflow.
  bool reserve_ids_through(std::int32_t id) {
    if (id < 1 || id > kMaxObjectId) return false;
    next_id_ = std::max(next_id_, id + 1);
    return true;
  }
  // A restarted merger resumes an object its tracker still holds: under its own id, with its model
  // (object frame, non-empty, at most max_model_points), version, pose and velocity as given; it
  // starts with confidence 1 and one model part, as if created now, but is not reported as created.
  // New objects get ids above it. Throws std::invalid_argument (nothing changed) for an id outside
  // [1, kMaxObjectId], an id in use, an empty or oversized model or a negative version.
  void resume_object(ManagedObject object);

 private:
  // process()'s steps, in order (the header's comment above the class).
  void take_estimates(const std::map<std::int32_t, ObjectEstimate>& estimates);  // 1 (then carry_hidden, companions)
  void segment(const ColoredCloud& scene);                                       // 2
  void update_models(const ColoredCloud& scene);                                 // 3 (then refit_parts)
  void retire_unsupported(const ColoredCloud& scene);                            // 4
  void index_clusters(std::span<const std::int32_t> cluster_of_point);           // clusters_ for steps 5 and 6
  void propagate_and_create(const ColoredCloud& scene);                          // 5 and 6
  void join_and_split(const ColoredCloud& scene, std::span<const std::int32_t> cluster_of_point);  // 7

  // Step 6: the object carried this frame that the histogram matches best (as RetiredObjects::match), or 0.
  std::int32_t carried_match(const ColorHistogram& histogram) const;
  // Step 6: the carried object id takes points when its model registers on them (keep_frame): its pose, model and
  // labels; false (nothing changed) when it does not register or there is no registration.
  bool take_points_carried(std::int32_t id, const ColoredCloud& scene, std::span<const int> points);
  // Step 6: the live object not seen this frame (held or lacking support, not created now) that a new object's
  // histogram and model match (RetiredObjects::match_unseen) is retired and remembered, to take its id back; 0 = none.
  std::int32_t retire_unseen_match(const ColorHistogram& histogram, const ObjectModel& model);
  // Step 6: the objects of grown_ born unknown that match a remembered one now take its id.
  void reidentify_grown_objects(const ColoredCloud& scene);

  // A cluster's points that no object explains (label 0): only they form new models.
  std::vector<int> unexplained_points(std::span<const int> cluster_points) const;
  // A cluster's unexplained points, split by the discovery when there is one, become objects; found_parts: their
  // parts when already found (PartFinder::find), else they are found here.
  void create_objects(const ColoredCloud& scene, std::span<const int> free_points,
                      const std::vector<std::vector<int>>* found_parts = nullptr);
  void create_object(const ColoredCloud& scene, std::span<const int> points);
  // A created object (create_object, or taking a remembered id back once grown) joins this frame: confidence 1,
  // created now, its points (scene indices) labelled, its record (tracked_) with its seeded model updater, its first
  // view's histogram and its birth. Returns its record.
  TrackedObject& add_object(ManagedObject object, std::span<const int> points, const ColorHistogram& first_seen,
                            std::uint64_t birth);
  // Step 6: the object that a persisting cluster's unexplained points enter the view with (entering_frames), or 0.
  std::int32_t entering_with(const ColoredCloud& scene, std::span<const int> free_points);
  // Step 6: whether most of a cluster's unexplained points lie inside a held object (held_birth_margin).
  bool inside_held_object(const ColoredCloud& scene, std::span<const int> free_points) const;
  // Step 5 for one cluster: labels propagated (LabelPropagation), young objects grown by the points they gained.
  void propagate_labels(const ColoredCloud& scene, std::span<const int> cluster_points);
  // Steps 5 and 6: object id gained `points` (labelled with it, sorted here): its support, and a young object's model
  // grown by them when they are a part (min_object_points), not a few fringe points.
  void gain_points(std::int32_t id, const ColoredCloud& scene, std::vector<int>& points);
  void grow_model(ManagedObject& object, const ColoredCloud& scene, std::span<const int> gained);
  // Step 3's re-fit of grown parts (PartRefit) of every object with a new estimate, on its segmented points.
  void refit_parts(const ColoredCloud& scene);
  // Step 7: siblings that moved as one rigid body join (RigidPartJoin).
  void join_rigid_parts();
  // Step 7: objects that occupy one space are one (OverlapJoin).
  void join_overlapping();
  // An object for the contact test (ModelContact): its model at this frame's pose, its bounding radius.
  PlacedModel placed(std::int32_t id) const;
  // Step 1's touch test of carrying and companions (ModelContact::touching, memoised per frame).
  bool touching(std::int32_t a, std::int32_t b, float distance);
  // Each (kept, joined) pair whose two objects are still live, in order (an earlier join may have taken one).
  void join_pairs(std::span<const std::pair<std::int32_t, std::int32_t>> joins);
  // joined's model and points go to kept; joined is retired.
  void join(std::int32_t kept, std::int32_t joined);
  // Step 7: objects whose parts moved apart are split (PartSplit).
  void split_separated_parts(const ColoredCloud& scene, std::span<const std::int32_t> cluster_of_point);
  // The objects born from one cluster are split again by the discovery in their first frames; where it disagrees
  // with them (DiscoveryOptions::confirm_frames, confirm_votes) its parts become the objects (DiscoveryConfirmation).
  void confirm_discovery(const ColoredCloud& scene);
  // This frame's parts become the objects: an object keeps its part (model rebuilt from it; other objects' points
  // in it join it), a part no object took is a new sibling (if it then moves as one rigid body with the others,
  // join_rigid_parts puts them together again); an object that took no part keeps its points.
  void adopt_parts(const ColoredCloud& scene, std::uint64_t birth, std::span<const int> all,
                   const std::vector<std::vector<int>>& parts, const PartMatch& match);
  // The object's model becomes the points (scene indices) in its frame, thinned evenly.
  void rebuild_model(ManagedObject& object, const ColoredCloud& scene, std::span<const int> points);
  void forget(std::int32_t id);  // an object that is gone: its record, its published state and its pairs' watches
  // Step 1's carrying of hidden (held) objects.
  void carry_hidden(const ColoredCloud& scene);
  // occlusion_ with this frame's scene set (indexed at the first call of a frame).
  OcclusionTest& scene_occlusion(const ColoredCloud& scene);
  // Step 1's companions.
  void choose_companions();
  // object (made from points, scene indices) takes the remembered id known back: its version goes on from the
  // remembered one's and, with the registration, its frame and model (keep_frame); known is remembered no more.
  void take_id_back(std::int32_t known, const ColoredCloud& scene, std::span<const int> points, ManagedObject& object);
  // Registers a known model (at its last pose, with its parts) on the points (scene indices) of an object seen again
  // (re-identified, or carried): on success object gets the registered pose and that model with the points added,
  // and true is returned; else object is unchanged.
  bool keep_frame(const ObjectModel& model, const Pose& pose, std::span<const std::uint32_t> part_ends,
                  const ColoredCloud& scene, std::span<const int> points, ManagedObject& object);

  ObjectManagerOptions options_;
  ThreadPool pool_;   // one thread per discovery (at least one): the parts of born clusters, the segmentation
  PartFinder parts_;  // the discovery's parts of born clusters (at least min_object_points each)
  std::vector<Rgb8> part_colors_;
  std::vector<Eigen::Vector3f> part_points_;  // a part to append (with_part), model frame
  Segmenter segmenter_;
  NewObjectDetector detector_;
  SupportMonitor support_;
  OcclusionTest occlusion_;
  PartRefit refit_;
  std::map<std::int32_t, std::vector<Eigen::Vector3f>> segmented_;  // step 3's points of each object, camera frame
  std::vector<std::uint8_t> hidden_;                                // per segmentation_.object_ids entry
  // The live objects: what is published of each (objects()) and what the manager keeps for it, under the same ids
  // (add_object and forget change both).
  std::map<std::int32_t, ManagedObject> objects_;
  std::map<std::int32_t, TrackedObject> tracked_;
  RetiredObjects retired_;
  std::vector<UnseenObject> unseen_;  // step 6: retire_unseen_match's candidates
  std::vector<std::int32_t> grown_;   // objects whose models grew this frame (step 5)
  std::int32_t next_id_ = 1;
  std::int64_t frames_ = 0;
  std::uint64_t next_birth_ = 1;
  std::uint64_t current_birth_ = 0;
  RigidPartJoin joiner_;        // step 7
  PartSplit splitter_;          // step 7
  OverlapJoin overlap_joiner_;  // step 7
  std::vector<OverlapCandidate> overlap_candidates_;
  DiscoveryConfirmation confirmation_;  // step 7
  std::vector<JoinCandidate> join_candidates_;
  bool occlusion_scene_set_ = false;
  ModelContact contact_;  // steps 1 and 7
  CarryMonitor carry_;
  std::vector<CarryMonitor::Object> carry_objects_;
  std::optional<ViewBounds> view_;
  // This frame's objects gripped away while hidden, to retire.
  std::vector<std::int32_t> gripped_away_;
  ObjectManagerFrame frame_;
  SegmentationResult segmentation_;
  ClusterSet clusters_;
  std::size_t standing_clusters_ = 0;  // clusters_ [0, standing_clusters_) may become objects
  ObjectModel entering_;               // entering_with's unexplained points (camera frame) for the contact test
  std::vector<SegmentationObject> seg_objects_;
  std::vector<int> confirmed_;
  ColoredCloud segment_;
  LabelPropagation propagation_;                     // step 5
  std::map<std::int32_t, std::vector<int>> gained_;  // step 5: per object, the points it gained in one cluster
  std::unique_ptr<ModelRegistration> registration_;
  HypothesisData registration_points_;
};

}  // namespace mfot
