// Online adaptation of v_des in changing environments (paper Sec. IV-B) and the experiment that
// flies it. See online_adaptation.hpp for the method.
//
// Thread safety: an OnlineAdapter is used by one flight's thread only; the free functions use
// only their arguments.
#include "quadtune/engine/adaptation/online_adaptation.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "../experiment/field_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/engine/api/planner_registry.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/physics/depth_sensor.hpp"
#include "quadtune/sim/scenario.hpp"

namespace quadtune::engine {

namespace {

constexpr double kArcStep = 0.01;  // time step (s) of the arc-length search for P_s

std::string Key(const std::string& name) { return "adaptation." + name; }

// The time on `trajectory` at which its arc length from the start reaches `length`, and the
// total length; nullopt when it never does.
std::optional<double> TimeAtArcLength(const planning::Trajectory& trajectory, double length,
                                      double* total) {
  const double duration = trajectory.Duration();
  double arc = 0.0;
  std::optional<double> found;
  Eigen::Vector3d last = trajectory.Position(0.0);
  for (double t = kArcStep;; t += kArcStep) {
    const double tc = std::min(t, duration);
    const Eigen::Vector3d p = trajectory.Position(tc);
    const double step = (p - last).norm();
    if (!found && arc + step >= length && step > 0.0) {
      found = tc - kArcStep + std::min(kArcStep, (length - arc) / step * kArcStep);
    }
    arc += step;
    last = p;
    if (tc >= duration) break;
  }
  *total = arc;
  return found;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// AdaptationOptions

ObjectiveOptions AdaptationOptions::DefaultObjective() {
  ObjectiveOptions o;
  o.short_kind = ObjectiveOptions::ShortKind::kChangingEnvironment;
  o.w_t = 1.0;
  o.w_p = 0.01;
  o.w_c = ObjectiveOptions::kDefaultClearanceWeight;
  o.clearance = 0.5;
  o.failure_value = 50.0;
  return o;
}

optimizers::BayesOptOptions AdaptationOptions::DefaultBayesOpt() {
  optimizers::BayesOptOptions o;
  o.initial_design_size = 3;
  o.noise_growth = 1.0;
  return o;
}

const Fields<AdaptationOptions>& AdaptationFields() {
  using A = AdaptationOptions;
  static const Fields<A> fields =
      Fields<A>()
          .Number("lookahead", &A::lookahead, {0.0, 20.0, true, false},
                  "R: arc length from a trajectory's start to P_s (m)")
          .Custom(
              {"v_des_bounds", "[lo, hi]", "[1, 6]", "0 < lo < hi ≤ 15",
               "bounds of the adapted v_des (m/s)"},
              [](const YamlMap& map, A& o) {
                if (!map.Has("v_des_bounds")) return;
                const std::vector<double> b = map.Numbers("v_des_bounds", 2);
                if (!(b[0] > 0.0) || !(b[1] > b[0]) || !(b[1] <= 15.0)) {
                  map.Fail("v_des_bounds", "expected [lo, hi] with 0 < lo < hi <= 15 (m/s)");
                }
                o.v_min = b[0];
                o.v_max = b[1];
              },
              [](YAML::Emitter& out, const A& o) {
                out << YAML::Key << "v_des_bounds" << YAML::Value << YAML::Flow << YAML::BeginSeq
                    << o.v_min << o.v_max << YAML::EndSeq;
              })
          .Integer("trials_per_segment", &A::trials_per_segment, Range::Closed(1, 200),
                   "BO trials per P_s")
          .Number("min_remaining", &A::min_remaining, Range::NonNegative(),
                  "trajectory needed after P_s to start a segment (m)")
          .Number("braking_fraction", &A::braking_fraction, {0.0, 1.0, true, false},
                  "a plan starting faster than its v_des brakes at this fraction of a_max")
          .Custom(
              {"objective", "map", "w_t 1, w_p 0.01, w_c 100, C 0.5 m, failure value 50",
               "[objective](#objective); `short_term.kind` must be `changing_environment`",
               "f_s of a trial"},
              [](const YamlMap& map, A& o) {
                if (!map.Has("objective")) return;
                const YamlMap obj = map.Map("objective");
                ObjectiveFields().Read(obj, o.objective);  // over DefaultObjective()
                if (o.objective.short_kind != ObjectiveOptions::ShortKind::kChangingEnvironment) {
                  obj.Map("short_term", true)
                      .Fail("kind", "must be changing_environment for online adaptation");
                }
              },
              [](YAML::Emitter& out, const A& o) {
                out << YAML::Key << "objective" << YAML::Value;
                ObjectiveFields().Write(out, o.objective);
              })
          // bo is written by nothing here: BayesOptOptions has no writer.
          .Custom(
              {"bo", "map", "3 initial points, `noise_growth` 1", "[BO](#bayesian-optimisation)",
               "its seed is replaced per segment"},
              [](const YamlMap& map, A& o) {
                if (!map.Has("bo")) return;
                const YamlMap bo = map.Map("bo");
                o.bo = optimizers::BayesOptOptions::FromYaml(bo);
                const optimizers::BayesOptOptions d = AdaptationOptions::DefaultBayesOpt();
                if (!bo.Has("initial_design_size"))
                  o.bo.initial_design_size = d.initial_design_size;
                if (!bo.Has("noise_growth")) o.bo.noise_growth = d.noise_growth;
                if (bo.Has("seed"))
                  bo.Fail("seed", "the BO seeds derive from the experiment's seed");
              },
              [](YAML::Emitter&, const A&) {})
          .Choice("mode", &A::mode,
                  "`online`: BO over v_des (the paper's search); `context`: the context "
                  "policy's v_des, measured at every P_s, governs the planner's own plans; "
                  "`context_prior`: the policy's v_des first, then BO")
          .Number("risk_weight", &A::risk_weight, Range::NonNegative(),
                  "w_r: weight of the stopping risk J_r = max over the plan of "
                  "max(0, |v|²/(2 a_max) − free distance ahead)² (m²) added to f_s; 0: the "
                  "paper's f_s")
          .Number("risk_range", &A::risk_range, Range::Positive(),
                  "free distances of J_r are searched up to this (m): the sensor's range")
          .Number("risk_reaction_time", &A::risk_reaction_time, Range::NonNegative(),
                  "τ (s): J_r also asks for a clearance of τ·|v| beyond the inflation along "
                  "the plan; 0: off")
          .Custom(
              {"policy", "map", "none", "[context policy](#context-policy)",
               "v_des per measured free range (`quadtune policy` writes one from a density "
               "study); required by the context modes"},
              [](const YamlMap& map, A& o) {
                if (map.Has("policy")) o.policy = ContextPolicy::FromYaml(map.Map("policy"));
              },
              [](YAML::Emitter& out, const A& o) {
                if (!o.policy) return;
                out << YAML::Key << "policy" << YAML::Value;
                ContextPolicyFields().Write(out, *o.policy);
              });
  return fields;
}

void AdaptationOptions::Validate(const std::string& file) const {
  AdaptationFields().Check(*this, file, "adaptation.");
  CheckInRange(v_min, Range::Positive(), file, Key("v_des_bounds"));
  CheckInRange(v_max, {v_min, 15.0, true, false}, file, Key("v_des_bounds"));
  objective.Validate(file);
  if (objective.short_kind != ObjectiveOptions::ShortKind::kChangingEnvironment) {
    throw ConfigError(file, Key("objective.short_term.kind"),
                      "must be changing_environment for online adaptation");
  }
  bo.Validate();
  if (mode != AdaptationMode::kOnline && !policy) {
    throw ConfigError(file, Key("mode"),
                      std::string("mode ") + quadtune::ToString(mode) +
                          " needs adaptation.policy (v_des per measured free range; `quadtune "
                          "policy` learns one from a density study)");
  }
  if (policy) policy->Validate(file);
}

AdaptationOptions AdaptationOptions::FromYaml(const YamlMap& map) {
  AdaptationOptions o;
  AdaptationFields().Read(map, o);
  o.Validate(map.file());
  return o;
}

// ---------------------------------------------------------------------------------------------
// OnlineAdapter

struct OnlineAdapter::Pending {
  AdaptationSegment segment;
  planning::Trajectory trajectory;  // the executing trajectory P_s lies on
  Eigen::Vector3d v_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_s = Eigen::Vector3d::Zero();
  planning::PlannerParams params;  // in force when the segment started
  std::unique_ptr<optimizers::BayesOpt> bo;
  double last_trial_time = 0.0;
  std::size_t first_trial = 0;  // index of the segment's first trial in trials_
  std::optional<planning::PlanOutcome> best;
  bool best_reaches_waypoint = false;
};

namespace {

planning::LocalPlannerOptions WithSnapshot(planning::LocalPlannerOptions options,
                                           const planning::TrajectoryBackend& backend) {
  options.snapshot = backend.Snapshot();
  return options;
}

}  // namespace

OnlineAdapter::OnlineAdapter(const planning::TrajectoryBackend& backend,
                             const sim::FlightPlannerOptions& planner_options,
                             AdaptationOptions options)
    : backend_(backend),
      planner_(WithSnapshot(planner_options, backend)),
      limits_(planner_options.optimizer),
      options_(std::move(options)) {
  options_.Validate();
}

OnlineAdapter::~OnlineAdapter() = default;

void OnlineAdapter::Close(AdaptationSegment::Outcome outcome) {
  if (!pending_) return;
  AdaptationSegment& s = pending_->segment;
  s.outcome = outcome;
  if (outcome != AdaptationSegment::Outcome::kAdopted) s.v_des = s.v_des_before;
  segments_.push_back(s);
  pending_.reset();
  if (observer_) observer_(segments_.back());
}

void OnlineAdapter::OnTrajectory(double t0, const planning::Trajectory& trajectory,
                                 bool /*reaches_waypoint*/, const planning::PlannerParams& params) {
  Close(AdaptationSegment::Outcome::kSuperseded);
  double total = 0.0;
  const std::optional<double> split = TimeAtArcLength(trajectory, options_.lookahead, &total);
  if (!split || total - options_.lookahead < options_.min_remaining) return;

  auto p = std::make_unique<Pending>();
  AdaptationSegment& s = p->segment;
  s.index = static_cast<int>(segments_.size());
  s.t0 = t0;
  s.split_time = t0 + *split;
  s.p_s_W = trajectory.Position(*split);
  p->v_s = trajectory.Velocity(*split);
  p->a_s = trajectory.Acceleration(*split);
  s.speed_s = p->v_s.norm();
  s.v_des_before = params.v_des;
  s.v_des = params.v_des;
  p->trajectory = trajectory;
  p->params = params;
  p->last_trial_time = t0;
  p->first_trial = trials_.size();

  optimizers::Parameter v;
  v.name = "v_des";
  v.lower = options_.v_min;
  v.upper = options_.v_max;
  optimizers::BayesOptOptions bo = options_.bo;
  bo.seed = DeriveSeed(options_.seed, {0xada97, static_cast<std::uint64_t>(s.index)});
  p->bo = std::make_unique<optimizers::BayesOpt>(optimizers::ParameterSpace({v}), bo);
  pending_ = std::move(p);
}

void OnlineAdapter::RunTrial(double t, const planning::LocalMap& map,
                             const Eigen::Vector3d& waypoint_W) {
  Pending& p = *pending_;
  if (t > p.last_trial_time) p.bo->AdvanceAge(t - p.last_trial_time);
  p.last_trial_time = t;
  const std::optional<double> forced = p.segment.trials == 0 ? PolicyChoice(map) : std::nullopt;
  std::optional<optimizers::Candidate> c;
  if (!forced) c = p.bo->Ask(1).at(0);

  AdaptationTrial trial;
  trial.segment = p.segment.index;
  trial.trial = p.segment.trials;
  trial.time = t;
  trial.p_s_W = p.segment.p_s_W;
  trial.v_des = forced ? *forced : c->x[0];
  trial.from_policy = forced.has_value();

  planning::PlannerParams params = p.params;
  params.v_des = trial.v_des;
  params.max_attempts = std::min(params.max_attempts, 2);  // never the slowed-down retries
  const double tau = p.segment.split_time - p.segment.t0;
  std::optional<planning::PlanningQuery> query = planner_.MakeQuery(
      map, p.segment.p_s_W, p.v_s, p.a_s, waypoint_W, params, &p.trajectory, tau);
  ResolveRecord record;  // the objective's inputs, as a re-solve reports them
  std::optional<planning::PlanOutcome> outcome;
  if (!query) {
    trial.status = "front_end";
  } else {
    // A trial slower than the drone at P_s plans its braking: the planner may exceed the trial's
    // v_des while it slows at braking_fraction · a_max (the envelope checked below).
    if (trial.v_des < p.segment.speed_s) {
      query->braking_deceleration = options_.braking_fraction * params.a_max;
    }
    outcome = backend_.Solve(*query, params, planner_.options());
    const planning::PlanResult& r = outcome->result;
    bool accepted = outcome->Ok();
    trial.status = planning::ToString(r.status);
    if (!accepted && r.status == planning::PlanStatus::kDynamicsViolated &&
        trial.v_des < p.segment.speed_s) {
      const planning::TrajectoryOptimizerOptions& limits = limits_;
      const std::string why = planning::BrakingEnvelopeViolation(
          r.trajectory, p.segment.speed_s, trial.v_des, params.a_max, options_.braking_fraction,
          limits.limit_tolerance, limits.check_dt);
      accepted = why.empty();
      trial.status = accepted ? "braking" : why;
    }
    record.success = accepted;
    record.attempts = outcome->attempts;
    record.failed_attempts = outcome->failed_attempts;
    record.solve_time_s = outcome->solve_time_s;
    record.compute_units = outcome->compute_units;
    record.duration = r.duration;
    record.jerk_integral = r.cost.jerk;
    record.min_clearance = r.min_clearance;
    trial.compute_units = outcome->compute_units;
  }
  const ObjectiveValue f =
      ShortTermObjective(record, options_.objective, TimingMode::kReproducible);
  trial.success = record.success;
  trial.t_exe = record.duration;
  trial.jerk_integral = record.jerk_integral;
  trial.min_clearance = record.min_clearance;
  trial.j_c = f.terms.count("J_c") ? f.terms.at("J_c") : 0.0;
  if (trial.success) {
    trial.j_r = StoppingRisk(outcome->result.trajectory, map, params.a_max, options_.risk_range,
                             options_.risk_reaction_time, params.inflation);
  }
  trial.f_s = std::isfinite(f.value) ? f.value + options_.risk_weight * trial.j_r
                                     : options_.objective.failure_value;
  if (!trial.success) trial.f_s = options_.objective.failure_value;
  if (forced) {
    p.bo->Observe(Eigen::VectorXd::Constant(1, trial.v_des), trial.f_s);
  } else {
    p.bo->Tell(c->id, trial.f_s);
  }

  ++p.segment.trials;
  if (trial.success) {
    ++p.segment.successes;
    if (p.segment.best_trial < 0 || trial.f_s < p.segment.best_f_s) {
      p.segment.best_trial = trial.trial;
      p.segment.best_f_s = trial.f_s;
      p.best = std::move(outcome);
      p.best_reaches_waypoint = query->goal_is_mission_goal;
    }
  }
  trials_.push_back(std::move(trial));
}

std::optional<double> OnlineAdapter::PolicyChoice(const planning::LocalMap& map) {
  Pending& p = *pending_;
  const FreeRangeOptions measure = options_.policy ? options_.policy->measure : FreeRangeOptions{};
  p.segment.free_range = MeasureFreeRange(map, p.segment.p_s_W, p.v_s, measure);
  if (options_.mode == AdaptationMode::kOnline) return std::nullopt;
  const ContextPolicy& policy = *options_.policy;
  p.segment.policy_v_des =
      std::clamp(policy.VDes(policy.Clamp(p.segment.free_range)), options_.v_min, options_.v_max);
  if (options_.mode == AdaptationMode::kContext) context_v_des_ = p.segment.policy_v_des;
  return p.segment.policy_v_des;
}

std::optional<sim::AdaptedPlan> OnlineAdapter::OnTick(double t, const planning::LocalMap& map,
                                                      const Eigen::Vector3d& waypoint_W) {
  if (!pending_) return std::nullopt;
  if (options_.mode == AdaptationMode::kContext) {
    // The measured choice governs the FSM's own plans from now on (context_v_des); nothing is
    // planned from P_s.
    PolicyChoice(map);
    pending_->segment.v_des = *context_v_des_;
    Close(AdaptationSegment::Outcome::kAdopted);
    return std::nullopt;
  }
  const int n = options_.trials_per_segment;
  const double t0 = pending_->segment.t0;
  const double ts = pending_->segment.split_time;
  // Trial k is due at t0 + k (t_s − t0) / N; every trial still due runs at t_s.
  while (pending_->segment.trials < n &&
         (t >= ts || t >= t0 + (ts - t0) * pending_->segment.trials / n)) {
    RunTrial(t, map, waypoint_W);
  }
  if (t < ts) return std::nullopt;

  Pending& p = *pending_;
  if (p.segment.best_trial < 0) {
    Close(AdaptationSegment::Outcome::kNoSuccess);
    return std::nullopt;
  }
  AdaptationTrial& best = trials_[p.first_trial + static_cast<std::size_t>(p.segment.best_trial)];
  best.chosen = true;
  sim::AdaptedPlan plan;
  plan.start_time = ts;
  plan.outcome = std::move(*p.best);
  plan.reaches_waypoint = p.best_reaches_waypoint;
  plan.params = p.params;
  plan.params.v_des = best.v_des;
  // An accepted braking plan holds kDynamicsViolated; the Replanner executes successes only.
  plan.outcome.result.status = planning::PlanStatus::kSuccess;
  p.segment.v_des = best.v_des;
  Close(AdaptationSegment::Outcome::kAdopted);
  return plan;
}

// ---------------------------------------------------------------------------------------------
// AdaptExperiment

AdaptExperiment AdaptExperiment::LoadFile(const std::string& path) {
  const std::string text = ReadFileText(path);
  const std::string dir = std::filesystem::path(path).parent_path().string();
  return FromString(text, path, dir.empty() ? "." : dir);
}

// The closed loop's sensor and goal rule, the dense/sparse split and the corridor study's f_l.
Fields<AdaptExperiment> AddFlightKeys(Fields<AdaptExperiment> f) {
  using E = AdaptExperiment;
  const auto unwritten = [](YAML::Emitter&, const E&) {};
  f.Custom(
       {"sensor", "map", "48 x 32 pixels, 87° x 58°, 15 Hz, 5 m",
        "[depth sensor](#depth-sensor) keys", "the depth camera of every flight"},
       [](const YamlMap& map, E& e) {
         if (!map.Has("sensor")) return;
         physics::DepthSensorFields().Read(map.Map("sensor"), e.sensor);
         e.sensor.Validate(map.file());
       },
       unwritten)
      .Flag("goal_braking", &E::goal_braking,
            "horizon goals within stopping distance d of the mission goal get the terminal "
            "speed min(v_des, √(2 a_max d)) (EGO-Planner's local-target rule)")
      .Number("dense_below", &E::dense_below, Range::Positive(),
              "zones of a spacing below this are dense, the others sparse (m)")
      .Number("w_e", &E::w_e, Range::NonNegative(),
              "corridor studies: f_l = t_f + t_f·n_c + w_e·n_e (s per emergency stop)")
      .Number("failure_value", &E::failure_value, Range::Positive(),
              "corridor studies: f_l of a flight that does not finish");
  return f;
}

// The baselines and the adaptation (read last: the adaptation checks the planner's v_des).
Fields<AdaptExperiment> AddAdaptationKeys(Fields<AdaptExperiment> f) {
  using E = AdaptExperiment;
  f.Custom(
      {"baselines", "list", "[2]", "each in (0, 15]",
       "fixed v_des flown on the same map and seed for comparison (m/s)"},
      [](const YamlMap& map, E& e) {
        if (!map.Has("baselines")) return;
        e.baselines = map.Numbers("baselines");
        for (double v : e.baselines) {
          if (!(v > 0.0 && v <= 15.0)) {
            map.Fail("baselines", "each v_des must lie in (0, 15] (m/s)");
          }
        }
      },
      [](YAML::Emitter& out, const E& e) {
        out << YAML::Key << "baselines" << YAML::Value << YAML::Flow << e.baselines;
      })
      .Custom(
          MapDoc("adaptation", "the online adaptation, below", "see below"),
          [](const YamlMap& map, E& e) {
            e.adaptation = AdaptationOptions::FromYaml(map.Map("adaptation", true));
            if (e.params.v_des < e.adaptation.v_min || e.params.v_des > e.adaptation.v_max) {
              map.Fail("planner",
                       "v_des (the adapted flight's start value) must lie in "
                       "adaptation.v_des_bounds");
            }
          },
          [](YAML::Emitter& out, const E& e) {
            out << YAML::Key << "adaptation" << YAML::Value;
            AdaptationFields().Write(out, e.adaptation);
          });
  return f;
}

const Fields<AdaptExperiment>& AdaptExperimentFields() {
  using E = AdaptExperiment;
  // world and planner are written by nothing here: WorldOptions and PlannerParams have no writer.
  const auto unwritten = [](YAML::Emitter&, const E&) {};
  static const Fields<E> fields = AddAdaptationKeys(
      AddFlightKeys(Fields<E>())
          .Text("name", &E::name, {}, "name of the experiment")
          .Integer("seed", &E::seed, Range::Closed(0, 9.0e15),
                   "layout, world and BO seeds (`--seed` overrides)")
          .Custom(
              {"drone", "path", "`drones/research_1kg.yaml`", "a [drone](#drone) file",
               "the drone flown"},
              [](const YamlMap& map, E& e) {
                e.drone_file = ResolvePath(
                    map.String("drone", std::string("drones/research_1kg.yaml")), e.base_dir);
                map.CheckFile("drone", e.drone_file,
                              " (searched next to the experiment and in assets/)");
                e.drone = physics::LoadDroneDescription(e.drone_file);
              },
              [](YAML::Emitter& out, const E& e) {
                out << YAML::Key << "drone" << YAML::Value << e.drone_file;
              })
          .Custom(
              {"layout_file", "path", "one of `layout`, `layout_file` required",
               "a [layout options](#layout) file", "usually a zoned layout"},
              [](const YamlMap& map, E& e) {
                if (map.Has("layout") == map.Has("layout_file")) {
                  map.Fail("layout_file",
                           "give exactly one of layout (generator options) or layout_file");
                }
                if (!map.Has("layout_file")) return;
                e.layout_file = ResolvePath(map.String("layout_file"), e.base_dir);
                if (!PathExists(e.layout_file)) {
                  map.Fail("layout_file", "file '" + e.layout_file + "' not found");
                }
                e.layout = layout::LayoutOptions::LoadFile(e.layout_file);
              },
              [](YAML::Emitter& out, const E& e) {
                if (e.layout_file == e.file) return;
                out << YAML::Key << "layout_file" << YAML::Value << e.layout_file;
              })
          .Custom(
              {"layout", "map", "one of `layout`, `layout_file` required",
               "[layout options](#layout)", "the layout's generator options, in the file"},
              [](const YamlMap& map, E& e) {
                if (!map.Has("layout")) return;
                e.layout_file = e.file;
                e.layout = layout::LayoutOptions::FromYaml(map.Map("layout"));
              },
              [](YAML::Emitter& out, const E& e) {
                if (e.layout_file != e.file) return;
                out << YAML::Key << "layout" << YAML::Value;
                e.layout.ToYaml(out);
              })
          .Custom(
              {"world", "map", "ideal world", "[world options](#world)",
               "seed replaced by `seed`; pass-through collisions"},
              [](const YamlMap& map, E& e) {
                if (map.Has("world")) e.world = physics::WorldOptions::FromYaml(map.Map("world"));
                e.world.collision_response = physics::CollisionResponse::kPassThrough;
              },
              unwritten)
          .Number("max_time", &E::max_time, Range::Positive(), "flight time limit (s)")
          .Custom(
              {"planner", "map", "`type: ipopt`, planner defaults",
               "`type`: a registered type flown in the closed loop: `ipopt`, `ego`, or one a "
               "program registers with a back end ([own-planner.md](own-planner.md)); the "
               "other keys: [planner parameters](#planner-parameters)",
               "`type`: the planner every flight and every trial plans with; another type is "
               "refused, naming the key and the types allowed. The other keys: fixed "
               "parameters; `v_des` is the adapted flight's start value"},
              [](const YamlMap& map, E& e) {
                if (map.Has("planner")) {
                  // `type` picks the closed-loop planner; the other keys are PlannerParams.
                  const YamlMap planner = map.Map("planner");
                  e.planner_type = planner.String("type", e.planner_type);
                  (void)BuildClosedLoopBackend(e.planner_type, e.file, planner.KeyPath("type"));
                  YAML::Node params = YAML::Clone(planner.node());
                  params.remove("type");
                  e.params = planning::PlannerParams::FromYaml(
                      YamlMap(params, planner.file(), planner.path()));
                }
                e.params.Validate(e.file);
                sim::FlightOptions{}.planner.CheckParams(e.params, e.file);  // as the flights plan
              },
              unwritten));
  return fields;
}

AdaptExperiment AdaptExperiment::FromString(const std::string& text, const std::string& origin,
                                            const std::string& base_dir) {
  AdaptExperiment e;
  e.file = origin;
  e.base_dir = base_dir;
  AdaptExperimentFields().Read(YamlMap::FromString(text, origin), e);
  e.SetSeed(e.seed);
  return e;
}

void AdaptExperiment::SetSeed(std::uint64_t new_seed) {
  seed = new_seed;
  world.seed = DeriveSeed(seed, {0x3071d});
  adaptation.seed = DeriveSeed(seed, {0xada});
}

std::string FlightPolicy::Label(const AdaptationOptions& adaptation) const {
  if (fixed_v_des) {
    std::ostringstream label;
    label << "fixed_" << *fixed_v_des;
    return label.str();
  }
  return mode.value_or(adaptation.mode) == AdaptationMode::kContext ? "context" : "adapted";
}

AdaptFlight RunAdaptFlight(const AdaptExperiment& e, const layout::Layout& layout,
                           std::optional<double> fixed_v_des,
                           const std::function<void(const AdaptationSegment&)>& on_segment,
                           const std::atomic<bool>* cancel) {
  return RunAdaptFlight(e, layout, FlightPolicy{fixed_v_des, std::nullopt}, on_segment, cancel);
}

AdaptFlight RunAdaptFlight(const AdaptExperiment& e, const layout::Layout& layout,
                           const FlightPolicy& policy,
                           const std::function<void(const AdaptationSegment&)>& on_segment,
                           const std::atomic<bool>* cancel) {
  AdaptFlight out;
  out.adapted = !policy.fixed_v_des.has_value();
  planning::PlannerParams params = e.params;
  if (policy.fixed_v_des) params.v_des = *policy.fixed_v_des;
  params.Validate(e.file);
  out.v_des = params.v_des;
  out.label = policy.Label(e.adaptation);
  AdaptationOptions adaptation = e.adaptation;
  if (policy.mode) adaptation.mode = *policy.mode;

  const sim::Scenario scenario =
      sim::Scenario::OverLayout(layout, sim::MissionKind::kGoTo, e.drone, e.world, e.world.seed);
  std::shared_ptr<physics::World> world;
  sim::MakeWorld(scenario, world);
  sim::FlightOptions options;
  options.max_time = e.max_time;
  options.sensor = e.sensor;
  options.planner.goal_braking = e.goal_braking;
  // A lowered v_des (the adapter's or the context policy's) is flown down to, not failed.
  options.replanner.slow_down_fraction = adaptation.braking_fraction;
  options.replanner.slow_down_tolerance = options.planner.optimizer.limit_tolerance;
  options.replanner.slow_down_check_dt = options.planner.optimizer.check_dt;
  const std::shared_ptr<const planning::TrajectoryBackend> backend =
      BuildClosedLoopBackend(e.planner_type, e.file, "planner.type");
  sim::FlightHooks hooks;
  if (cancel != nullptr) hooks.cancelled = [cancel] { return cancel->load(); };
  std::unique_ptr<OnlineAdapter> adapter;
  if (out.adapted) {
    adapter = std::make_unique<OnlineAdapter>(*backend, options.planner, adaptation);
    if (on_segment) adapter->SetSegmentObserver(on_segment);
    hooks.adapter = adapter.get();
    if (adaptation.mode == AdaptationMode::kContext) {
      hooks.params_provider = [a = adapter.get()](double /*t*/, planning::PlannerParams& p) {
        if (const std::optional<double> v = a->context_v_des()) p.v_des = *v;
      };
    }
  }
  out.result = sim::Fly(*world, scenario.mission, params, options, *backend, hooks);
  if (adapter) {
    out.trials = adapter->trials();
    out.segments = adapter->segments();
  }
  return out;
}

}  // namespace quadtune::engine
