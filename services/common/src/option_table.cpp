// The option table: every configuration key declared once, in the order (and with the comments) of
// the generated configs/default.yaml. Change an option here, then regenerate the shipped files:
//   build/services/config/mfot-config --print-defaults > configs/default.yaml
//   build/services/config/mfot-config --print-docs > docs/options.md
// (tests/services/test_options.cpp fails while they differ). A range is inclusive at both ends and
// written as the loader checks it; a doc states the contract: meaning, unit, what 0 or false means.
#include "mfot/service/options.hpp"

namespace mfot::service {

namespace {

using K = OptionEntry::Kind;
using T = OptionType;

constexpr OptionEntry entry(K kind, std::string_view key, std::string_view doc) {
  OptionEntry e;
  e.kind = kind;
  e.key = key;
  e.doc = doc;
  return e;
}
constexpr OptionEntry option(std::string_view key, T type, std::string_view value, std::string_view doc) {
  OptionEntry e = entry(K::kOption, key, doc);
  e.type = type;
  e.default_value = value;
  return e;
}

constexpr OptionEntry blank() { return {}; }
// A comment paragraph inside mapping `scope` ("" = the top level).
constexpr OptionEntry note(std::string_view scope, std::string_view text) { return entry(K::kNote, scope, text); }
constexpr OptionEntry mapping(std::string_view key, std::string_view doc) { return entry(K::kMapping, key, doc); }
constexpr OptionEntry flag(std::string_view key, std::string_view value, std::string_view doc) {
  return option(key, T::kBool, value, doc);
}
constexpr OptionEntry text(std::string_view key, std::string_view value, std::string_view doc) {
  return option(key, T::kString, value, doc);
}
constexpr OptionEntry choice(std::string_view key, std::string_view value, std::string_view choices,
                             std::string_view doc) {
  OptionEntry e = option(key, T::kChoice, value, doc);
  e.choices = choices;
  return e;
}
constexpr OptionEntry list(std::string_view key, std::string_view value, int size, std::string_view unit,
                           std::string_view doc) {
  OptionEntry e = option(key, T::kList, value, doc);
  e.size = size;
  e.unit = unit;
  return e;
}
constexpr OptionEntry ranged(T type, std::string_view key, std::string_view value, std::string_view min,
                             std::string_view max, std::string_view unit, std::string_view doc) {
  OptionEntry e = option(key, type, value, doc);
  e.min = min;
  e.max = max;
  e.unit = unit;
  return e;
}
constexpr OptionEntry integer(std::string_view key, std::string_view value, std::string_view min, std::string_view max,
                              std::string_view unit, std::string_view doc) {
  return ranged(T::kInteger, key, value, min, max, unit, doc);
}
constexpr OptionEntry number(std::string_view key, std::string_view value, std::string_view min, std::string_view max,
                             std::string_view unit, std::string_view doc) {
  return ranged(T::kNumber, key, value, min, max, unit, doc);
}
// A number above min (min itself refused) and at most max: (min, max].
constexpr OptionEntry number_above(std::string_view key, std::string_view value, std::string_view min,
                                   std::string_view max, std::string_view unit, std::string_view doc) {
  OptionEntry e = ranged(T::kNumber, key, value, min, max, unit, doc);
  e.min_open = true;
  return e;
}

// clang-format off
constexpr OptionEntry kTable[] = {
    note("", "mfot's defaults, generated from the option table (services/common/src/option_table.cpp) by\nmfot-config --print-defaults: change an option there, not here (tests/services/test_options.cpp\nfails while the two differ); docs/options.md lists the same. The build embeds this file; a\nconfig of your own (--config) holds only what it changes and is laid over it, key by key. As\nshipped: the built-in `stack` simulator scenario through the whole process group on the CPU or\nGPU (auto). Every service reads its own section; unknown keys and out-of-range values are refused\nat start with the key and the allowed range.\nUnits: metres, radians, milliseconds unless a key says otherwise."),
    blank(),
    mapping("group", "scripts/mfot-run; the services read id, key_file and max_message_age_s (docs/architecture.md, \"Several hosts\")"),
    integer("group.id", "1", "1", "9007199254740992", "", "this group's id (at most 2^53): every message carries it and services ignore (count as foreign) other ids' traffic; mfot-run refuses to start where a group with this id already runs on the URL"),
    text("group.key_file", "\"\"", "HMAC-SHA256 key authenticating every message, \"\" = none: a file of 32 to 4096 bytes readable by its owner only (chmod 600; e.g. head -c 32 /dev/urandom > key), the same on every host of the group"),
    number("group.max_message_age_s", "30", "0", "3600", "s", "with a key: a message stamped further than this from the receiver's clock is a replay; 0 = off"),
    number_above("group.peer_listen_s", "1.5", "0", "30", "s", "before starting, mfot-run listens this long on MFOT_STATUS for a group with the same id"),
    integer("group.workers", "6", "1", "64", "", "tracker worker pool size; objects beyond it wait (stale) for a free worker"),
    integer("group.max_restarts", "3", "", "", "", "restarts of a crashed service before the group gives up on it (a refused configuration is never restarted; without the merger or preprocess the group stops)"),
    number("group.drain_timeout_s", "5", "", "", "s", "after a finite source ends, wait at most this long for the last poses"),
    number("group.ready_timeout_s", "30", "", "", "s", "wait at most this long for every service's first status before starting the source"),
    note("group", "lcm_url: \"udpm://239.255.76.67:7667?ttl=0\"  (unset: host-local; LCM has no authentication)"),
    blank(),
    mapping("capture", ""),
    choice("capture.source", "sim", "sim|tum|pcd|oni|openni2|lcmlog", ""),
    choice("capture.rate", "lockstep", "realtime|fast|lockstep", "realtime: at the source's timestamps; fast: as fast as possible; lockstep: at most lockstep_window frames without poses on MFOT_POSES"),
    integer("capture.lockstep_window", "1", "1", "8", "", "lockstep: frames out whose poses have not come back. 1: a frame's latency is its own processing; 2-4 overlap preprocessing of the next frames with tracking of this one (more frames/s on many cores, each frame waiting for those ahead). Results are identical for every window (trackers wait for the previous frame's models); needs preprocess.queue_frames >= window and tracker.queue_scenes >= window (scripts/mfot-run raises them for its run)"),
    number("capture.lockstep_timeout_s", "5.0", "0.001", "3600", "s", "lockstep: wait this long for a frame's poses, then warn and go on"),
    number("capture.speed", "1.0", "0.001", "100", "", "realtime playback speed factor; also the .oni playback speed"),
    integer("capture.max_frames", "0", "0", "", "", "frames to publish, 0 = unlimited"),
    integer("capture.start_frame", "0", "0", "", "", "first source frame (also where --loop restarts)"),
    flag("capture.loop", "false", "restart a finite source (sim, tum, oni, lcmlog) at its end instead of exiting"),
    text("capture.groundtruth_dir", "\"\"", "write ground truth here (poses.csv, labels/<seq %06d>.png), \"\" = none; sources with ground truth: sim, and tum folders written by mfot-simulate"),
    blank(),
    note("capture", "Wire encoding of frame_t (lcmtypes/frame_t.lcm)"),
    choice("capture.depth_encoding", "rvl", "raw|zlib|rvl", "all lossless; rvl (run-length + delta coding) is the fastest"),
    choice("capture.color_encoding", "jpeg", "raw|jpeg|png", "jpeg is lossy, png lossless"),
    integer("capture.jpeg_quality", "90", "1", "100", "", ""),
    integer("capture.zlib_level", "1", "0", "9", "", "zlib depth and PNG colour compression level"),
    blank(),
    note("capture", "source: sim (the built-in simulator; timestamps are the scenario time)"),
    choice("capture.scenario", "stack", "stack|contact|rotate|apart|static|random|spin|tumble|slide|cross|procedural",
           "procedural: a seeded generated scene (1-20 boxes, cans, bottles, mugs; plain, striped, labelled, checkered; one motion class of slide, push, spin, tilt, stack, tumble; moved by a hand, a gripper or nothing visible; random camera height and pitch); its motion class and shapes are in the source name and in groundtruth_dir/scene.yaml"),
    integer("capture.seed", "1", "0", "", "", "scene (random, spin, tumble, slide, cross, procedural) and sensor-noise seed; procedural seeds 1-999 are for development, 1000 and up for acceptance only (never tune on them)"),
    integer("capture.sim_frames", "0", "0", "1000000", "", "frames to render, 0 = the scenario's own length"),
    flag("capture.sim_noise", "true", "Kinect-like sensor noise and dropouts"),
    integer("capture.sim_objects", "3", "1", "16", "", "the random scenario's objects on the table (procedural draws its own)"),
    blank(),
    note("capture", "source: tum (a TUM RGB-D folder: rgb.txt, depth.txt, PNGs; its intrinsics.txt when present, else tum_intrinsics)"),
    text("capture.folder", "\"\"", "required for source tum and pcd (--folder)"),
    number("capture.depth_scale", "5000.0", "0.001", "1000000000", "", "depth PNG units per metre (TUM: 5000)"),
    number("capture.max_time_difference_s", "0.02", "1e-6", "10", "s", "rgb/depth association tolerance"),
    list("capture.tum_intrinsics", "[525.0, 525.0, 319.5, 239.5]", 4, "", "fx fy cx cy, pixels, of a folder without intrinsics.txt (the folder's file wins)"),
    blank(),
    note("capture", "source: pcd (a folder of organised PCD files, x y z rgb/rgba, played in natural name order; depth from z, the intrinsics fitted to each cloud; unusable files are skipped with an error naming them)"),
    number("capture.pcd_fps", "30.0", "0.001", "1000", "", "frames per second the folder is played at (PCD files carry no time); the folder is `folder`"),
    integer("capture.pcd_background_label_max", "0", "0", "65534", "", "a `label` field is ground truth for mfot-evaluate; labels up to this are background (mOSD: 9, its labels 1-9 are the table; objects' parts are 20-29, 30-39, ...)"),
    blank(),
    note("capture", "source: lcmlog (a recorded run's MFOT_FRAME events, published as recorded: replay)"),
    text("capture.log_file", "\"\"", "required for source lcmlog (--log; scripts/mfot-run --replay sets it)"),
    blank(),
    note("capture", "source: oni (an OpenNI2 recording, played frame by frame and paced by `rate` and `speed`)"),
    text("capture.oni_file", "\"\"", "required for source oni (--oni)"),
    blank(),
    note("capture", "source: openni2 (live camera, depth registered to colour, 640x480 at 30 Hz)"),
    text("capture.device_uri", "\"\"", "\"\" = the first device found"),
    number("capture.reopen_max_backoff_s", "10.0", "0.5", "600", "s", "a lost camera is reopened with back-off doubling up to this"),
    blank(),
    mapping("preprocess", ""),
    note("preprocess", "Workspace crop: an axis-aligned box in the camera frame (x right, y down, z forward); crop_min < crop_max on every axis. Points outside are dropped before anything else."),
    list("preprocess.crop_min", "[-1.5, -1.5, 0.3]", 3, "m", "lower corner x, y, z"),
    list("preprocess.crop_max", "[1.5, 1.5, 2.0]", 3, "m", "upper corner x, y, z"),
    blank(),
    note("preprocess", "Table removal: a RANSAC plane is fitted, kept between frames, and refitted only when it stops fitting. Points more than plane_margin above it (camera side) are kept."),
    flag("preprocess.remove_plane", "true", "false: keep the table (scenes without one)"),
    integer("preprocess.ransac_iterations", "100", "1", "100000", "", "hypotheses per fit (a fixed count: deterministic cost)"),
    integer("preprocess.ransac_sample_points", "2048", "3", "1000000", "", "points the hypotheses are scored on, an even stride"),
    number("preprocess.plane_inlier_distance", "0.01", "0.0001", "0.5", "", "inlier band of the plane"),
    number("preprocess.plane_min_inlier_share", "0.1", "0.001", "1", "", "a fit is the table only with at least this share of the cropped points as inliers"),
    number("preprocess.plane_keep_ratio", "0.7", "0.001", "1", "", "refit when the kept plane's inlier share falls below this fraction of its share when fitted"),
    number("preprocess.plane_margin", "0.01", "0", "0.5", "", "keep points more than this above the plane"),
    number("preprocess.plane_margin_sigmas", "3.0", "0", "10", "", "... or this many depth-noise sigmas where that is more (far away): 1 cm up to 1.45 m, 1.8 cm at 2 m; 0 = fixed"),
    list("preprocess.depth_sigma", "[0.0012, 0.0019, 0.4]", 3, "m", "sensor depth noise sigma(z) = base + quadratic (z - reference)^2 (Nguyen et al. 2012, Kinect v1)"),
    flag("preprocess.table_prism", "true", "clusters must stand on the table: less than prism_min_share of a cluster's voxels above the convex hull of the plane's inliers and it never becomes an object (walls, shelves, people beside the table; it still carries the labels of an object tracked into it, as a gripper raised beyond the table's far edge), unless it rests on the table between the inlier regions a pile cuts its top into (its lowest voxel at the table, or its foot hidden behind a nearer standing cluster or below the image); false = any cluster (scenes without a table)"),
    number("preprocess.prism_min_share", "0.25", "0.001", "1", "", ""),
    integer("preprocess.seed", "502558", "0", "", "", "seed of the RANSAC generator and of the voxel grid's draws"),
    blank(),
    note("preprocess", "Voxel-grid downsampling: mean position and colour per voxel (thesis: 5 mm)."),
    number("preprocess.voxel_size", "0.005", "0.0001", "1", "", "leaf"),
    flag("preprocess.voxel_jitter", "false", "true: each frame's grid corner drawn within one leaf from seed and the frame's seq (the same in any replay). On a fixed grid (false, the thesis) a surface at rest gives the same voxel means every frame: still objects stay exactly put, but ICP onto a model sampled on that grid can hold a box that starts to turn back for a few frames; a moving grid frees it and makes still objects read noisier (docs/experiment-log.md: \"A voxel grid that moves every frame\")"),
    blank(),
    note("preprocess", "Euclidean clustering of the voxels (connected components closer than cluster_tolerance)."),
    flag("preprocess.cluster", "true", "false: every scene point in one cluster index -1 (no new objects)"),
    number("preprocess.cluster_tolerance", "0.015", "0.0001", "1", "", ""),
    integer("preprocess.cluster_min_size", "30", "1", "10000000", "", "voxels; smaller clusters get index -1; no cluster is too large (a pile is one)"),
    blank(),
    note("preprocess", "Service: threads and queue (mfot-preprocess; the in-process runner uses threads too)."),
    integer("preprocess.threads", "0", "0", "64", "", "threads per frame, the service's own included; 0 = a quarter of the machine's cores, at least 1 and at most 8 (2 cores: 1; 16 cores: 4): the group's trackers, merger and capture need the rest. The scene is bit-identical for every count"),
    integer("preprocess.queue_frames", "1", "1", "64", "", "frames waiting for preprocessing, in order: 1 = always the newest (a live camera's lowest latency); lockstep needs capture.lockstep_window (scripts/mfot-run raises it)"),
    blank(),
    mapping("tracker", ""),
    choice("tracker.backend", "auto", "auto|cuda|cpu|point-to-point", "auto: CUDA when a GPU is usable, else the CPU; cuda: refused at start when no GPU can start; point-to-point: the point-to-point likelihood on the CPU"),
    integer("tracker.particles", "100", "1", "100000", "", "particles per object; the thesis's real-time point is 100"),
    integer("tracker.threads", "1", "1", "256", "", "CPU JCSD threads across particles"),
    integer("tracker.cuda_device", "0", "0", "64", "", "CUDA device ordinal"),
    number("tracker.cell_size", "0.015", "0.001", "0.2", "m", "JCSD grid cell = kernel bandwidth r"),
    number_above("tracker.lambda", "80.0", "0", "1000", "", "likelihood sharpness of eq. 3.21"),
    choice("tracker.resampling", "systematic", "multinomial|systematic", "the resampling of Algorithm 1"),
    list("tracker.init_sigma", "[0.002, 0.002, 0.002, 0.00875, 0.00875, 0.00875]", 6, "", "C_init std devs (x, y, z m; roll, pitch, yaw rad)"),
    number("tracker.diffusion_a", "0.02", "0", "100", "", "C_t = a dX dX^T + b C_init (eq. 2.14)"),
    number("tracker.diffusion_b", "1.0", "0", "100", "", "weight b of C_init in C_t"),
    number("tracker.predicted_fraction", "0.5", "0", "1", "", "share of particles moved by the last motion dX (eq. 2.15)"),
    integer("tracker.icp_iterations", "10", "0", "50", "", "every stepped frame's estimate refined on the model's surface: coloured ICP iterations (each scored point paired with the model point nearest in position and colour; occluders and claimed points left out) onto the model (IcpRefinement); 0 = the thesis (the particles' weighted mean). The JCSD score is smooth over its 15 mm kernel, so a turning object's estimate lags several degrees at some views; the surface and its colours pin it"),
    number("tracker.icp_max_distance", "0.01", "0.0001", "0.1", "m", "a scored point pairs with the nearest model point this close"),
    integer("tracker.max_hold_frames", "90", "1", "100000", "", "at most this many holds in a row (90 = 3 s at 30 frames/s): a hold cannot tell a hidden object from one whose estimate slipped behind a surface, so after this the filter steps on every point in the margin (thesis) until the occlusion clears"),
    integer("tracker.seed", "1", "0", "", "", "filter seed; each object adds its id"),
    integer("tracker.heartbeat_ms", "100", "10", "10000", "ms", "worker heartbeat period"),
    integer("tracker.merger_timeout_ms", "1500", "100", "600000", "ms", "models are taken only from the group's merger process (the first heard, envelope_t.sender); another merger's only once it was silent (no model, no status) this long"),
    integer("tracker.queue_scenes", "1", "1", "64", "", "scenes a worker keeps, in frame order, until it may track them; beyond it the oldest is skipped (told to the merger at once). At least capture.lockstep_window; 1 = the newest only"),
    integer("tracker.model_wait_ms", "5000", "1", "600000", "ms", "a scene waits at most this long for its object's model of the frame before, then is tracked with the model held (counted in MFOT_STATUS). Healthy runs never wait this long: the merger's estimate timeout, or its re-send of a lost model, comes first"),
    blank(),
    mapping("merger", ""),
    number("merger.tau", "0.010", "0.0001", "0.1", "m", "segmentation threshold (eq. 3.23): 2 x the 5 mm voxel"),
    number("merger.alpha", "0.0", "0", "1", "", "model forgetting factor (thesis 3.4: 0.02). Measured (docs/experiment-log.md): 0.02 lets static objects' frames drift 5-9 mm on stack and contact, so models stay as first seen (plus growth)"),
    integer("merger.seed", "1", "0", "", "", "model-update seed; each object adds its id"),
    integer("merger.min_object_points", "50", "1", "100000", "", "smaller clusters never become objects"),
    integer("merger.max_model_points", "1500", "1", "100000", "", "a model never holds more points: a new one is subsampled, a growing one (growth_frames) thins out evenly over its whole extent"),
    number("merger.propagation_radius", "0.015", "0", "0.1", "m", "unexplained points of a cluster take the nearest segmented point's label through steps of at most this; 0 = off"),
    number("merger.propagation_min_seed_share", "0.1", "0", "1", "", "... only in a cluster at least this share of whose points are segmented; 0 = any: a box the hand brings back (or puts down) stays free to be found again instead of taking the hand's label from the few points of the hand's model that reach into its cluster"),
    integer("merger.growth_frames", "300", "0", "100000", "", "an object younger than this (frames) grows its model by the points it gains so (entering the view)"),
    integer("merger.reidentify_frames", "900", "0", "1000000", "", "a retired object is remembered this many frames; a new object matching its colours (when born, or as its model grows) takes its id back, and its remembered model is registered on the new points so that it keeps its object frame; 0 = off"),
    number("merger.reidentify_similarity", "0.9", "0.001", "1", "", "least Bhattacharyya coefficient of the 8-bin SMR colour histograms for that match"),
    integer("merger.new_object_frames", "3", "1", "1000", "", "frames an unexplained cluster must persist to become an object"),
    integer("merger.retire_min_points", "20", "0", "100000", "", "an object with fewer segmented points lacks support ..."),
    integer("merger.retire_frames", "5", "1", "10000", "", "... and is retired after this many such frames in a row"),
    integer("merger.estimate_timeout_ms", "500", "1", "600000", "ms", "wait this long for the trackers' estimates of a frame; late objects are marked stale"),
    integer("merger.worker_timeout_ms", "1000", "100", "600000", "ms", "a worker silent this long is dead: its object goes to another worker"),
    integer("merger.expected_workers", "0", "0", "1000", "", "workers the first frame waits for (scripts/mfot-run sets it)"),
    integer("merger.startup_timeout_ms", "10000", "0", "600000", "ms", "wait this long for expected_workers before the first frame"),
    integer("merger.resume_listen_ms", "300", "0", "10000", "ms", "after a start, finish no frame for this long while workers that hold objects this merger does not know are asked for them (a restarted merger resumes their ids, models, poses and owners)"),
    integer("merger.resume_timeout_ms", "500", "1", "10000", "ms", "a worker asked for its object answers within this long, else the object is retired"),
    integer("merger.threads", "0", "0", "64", "", "the merger's threads: the segmentation's ranges of scene points, and a frame's born clusters split into parts (supervoxels + LCCP: the first frame's, the young objects' confirmations), side by side; 0 = a quarter of the machine's cores, as preprocess.threads. The output is the same for every count"),
    flag("merger.write_labels", "true", "write labels/<frame>.png next to poses.csv (mfot-run: drawn from the log after the run, by mfot-labels)"),
    flag("merger.fitting_distance", "true", "write fitting.csv (thesis eq. 4.1, 4.2)"),
    note("merger", "Object discovery where objects are born (the first frame, a cluster no object explains): `lccp` splits such a cluster into its locally convex connected parts (PCL's supervoxels + LCCP, Stein et al. 2014), so touching and stacked objects are found apart from the first frame (the thesis makes each Euclidean cluster one object). Runs only at birth, never per frame. Supervoxel and LCCP settings as PCL's example_lccp_segmentation (docs/method.md, Constants)."),
    mapping("merger.discovery", ""),
    number("merger.discovery.seed_resolution", "0.02", "0.0075", "0.5", "m", "supervoxel seed spacing, at least the 7.5 mm supervoxel leaf; 3 cm straddles the step between touching boxes' front faces and joins them (docs/experiment-log.md: \"Touching boxes a step apart\")"),
    number("merger.discovery.color_cut", "0", "0", "200", "", "supervoxels LCCP joins stay joined only while their mean colours' CIELab a*b* (at one lightness, so shading does not count) are this close: touching objects with flush faces or level caps come apart by colour (35 took piles apart on synthetic piles, but split a striped can: off until the cut tells texture from a boundary); 0 = off (convexity alone)"),
    integer("merger.discovery.min_part_points", "400", "1", "100000", "", "parts with fewer scene points join the neighbouring part they touch (no tiny objects; 400 voxels of 5 mm: 100 cm2 of seen surface, more than a bottle's neck and cap show, less than a box)"),
    note("merger", "The merger's other steps run with the method's constants and take no options (docs/departures.md; their settings in docs/method.md, Constants): the discovery confirmed over an object's first 15 frames, point-level boundaries between discovered parts, join and split by motion, hidden objects carried by the object they moved with, grown parts re-fitted on the first view, and each object's companion (the touching object whose motion moves half of the particles its own last motion leaves unpredicted)."),
    mapping("merger.world", "camera pose in the world frame, for world_position/world_orientation"),
    list("merger.world.translation", "[0.0, 0.0, 0.0]", 3, "m", "camera position in the world"),
    list("merger.world.rotation", "[1.0, 0.0, 0.0, 0.0]", 4, "", "unit quaternion w, x, y, z"),
    blank(),
    note("", "mfot-pcl-baseline only: PCL's KLDAdaptiveParticleFilterOMPTracker with the settings of PCL's tracking example (apps/src/openni_tracking.cpp), one per object, on mfot's frames (configs/pcl_baseline.yaml changes nothing by default)."),
    mapping("pcl_baseline", ""),
    integer("pcl_baseline.particles", "400", "1", "100000", "", "initial particle count (setParticleNum)"),
    integer("pcl_baseline.max_particles", "500", "1", "100000", "", "KLD bound's ceiling (setMaximumParticleNum), at least particles"),
    number("pcl_baseline.kld_delta", "0.99", "1e-6", "0.999999", "", "KLD bound confidence (setDelta)"),
    number("pcl_baseline.kld_epsilon", "0.2", "1e-6", "10", "", "KLD bound error (setEpsilon)"),
    number("pcl_baseline.bin_size", "0.1", "1e-6", "10", "", "KLD histogram bin in every state dimension, m and rad (setBinSize)"),
    note("pcl_baseline", "Std devs x, y, z (m), roll, pitch, yaw (rad), each [0, 1]. PCL takes variances: the example's 0.015^2 (x 40 for the angles) and 1e-5."),
    list("pcl_baseline.step_noise_sigma", "[0.015, 0.015, 0.015, 0.0949, 0.0949, 0.0949]", 6, "", "diffusion per step"),
    list("pcl_baseline.initial_noise_sigma", "[0.00316, 0.00316, 0.00316, 0.00316, 0.00316, 0.00316]", 6, "", "around the first pose"),
    integer("pcl_baseline.iterations", "1", "1", "100", "", "filter iterations per frame (setIterationNum)"),
    number("pcl_baseline.color_weight", "0.1", "0", "100", "", "HSVColorCoherence weight; DistanceCoherence keeps weight 1"),
    number("pcl_baseline.max_distance", "0.01", "1e-6", "1", "m", "nearest pairs farther than this add nothing (ApproxNearestPairPointCloudCoherence)"),
    number("pcl_baseline.octree_resolution", "0.01", "0.0001", "1", "m", "pcl::search::Octree leaf of the coherence's search"),
    number("pcl_baseline.reference_leaf", "0.01", "0", "0.1", "m", "the reference (our first-frame model) is voxelised to this leaf like the example's input; 0 keeps it"),
    integer("pcl_baseline.threads", "1", "1", "256", "", "OpenMP threads of the OMP tracker (1: comparable with mfot-inprocess on one core)"),
    integer("pcl_baseline.seed", "1", "0", "4294967295", "", "seeds rand(), the only generator of PCL's tracker its API lets us seed"),
    blank(),
};
// clang-format on

}  // namespace

std::span<const OptionEntry> option_table() { return kTable; }

}  // namespace mfot::service
