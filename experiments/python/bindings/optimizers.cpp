// _core.Optimizer: quadtune's ask/tell optimisers (optimizers/) behind one Python class. The
// space and the options arrive as YAML text (the Python side writes dicts as JSON, which is
// YAML), read by ParameterSpace::FromYaml and the `bo:` / `pso:` loaders of experiment files, so
// a bad key or value raises ValueError (ConfigError) naming the key and what is allowed.
#include <pybind11/stl.h>

#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "bindings.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/optimizers/bayes_opt.hpp"
#include "quadtune/optimizers/pso.hpp"
#include "quadtune/optimizers/random_search.hpp"

namespace quadtune::python {

namespace py = pybind11;
namespace opt = optimizers;

namespace {

using Clock = std::chrono::steady_clock;

/// One optimiser and the time spent inside its Ask and Tell (for the overhead benchmark).
class Optimizer {
 public:
  /// `method`: bo | pso | random. `space_yaml`: {parameters: [...]}; `options_yaml`: {METHOD:
  /// {...}} with the keys of an experiment's `bo:` or `pso:` map ({random: {}} takes none).
  Optimizer(const std::string& method, const std::string& space_yaml,
            const std::string& options_yaml, std::uint64_t seed) {
    space_ = opt::ParameterSpace::FromYaml(YamlMap::FromString(space_yaml, "space"));
    const YamlMap options = YamlMap::FromString(options_yaml, "options");
    options.RejectUnknownKeys({method});
    const YamlMap section = options.Map(method, true);
    if (method == "bo") {
      opt::BayesOptOptions o = opt::BayesOptOptions::FromYaml(section);
      o.seed = seed;
      optimizer_ = std::make_unique<opt::BayesOpt>(space_, o);
    } else if (method == "pso") {
      opt::PsoOptions o = opt::PsoOptions::FromYaml(section);
      o.seed = seed;
      optimizer_ = std::make_unique<opt::Pso>(space_, o);
    } else if (method == "random") {
      if (!section.Keys().empty())
        section.Fail(section.Keys().front(), "unknown key; random search takes no options");
      optimizer_ = std::make_unique<opt::RandomSearch>(space_, opt::RandomSearchOptions{seed});
    } else {
      throw ConfigError("", "method", "got '" + method + "', allowed: bo, pso, random");
    }
  }

  /// Up to k candidates as (id, values in space order).
  std::vector<std::pair<opt::CandidateId, std::vector<double>>> Ask(int k) {
    const std::lock_guard lock(mutex_);
    const auto start = Clock::now();
    const std::vector<opt::Candidate> candidates = optimizer_->Ask(k);
    ask_s_ += std::chrono::duration<double>(Clock::now() - start).count();
    std::vector<std::pair<opt::CandidateId, std::vector<double>>> out;
    out.reserve(candidates.size());
    for (const opt::Candidate& c : candidates) {
      out.emplace_back(c.id, std::vector<double>(c.x.data(), c.x.data() + c.x.size()));
    }
    return out;
  }

  void Tell(opt::CandidateId id, double value, std::optional<double> noise_variance) {
    const std::lock_guard lock(mutex_);
    const auto start = Clock::now();
    optimizer_->Tell(id, value, noise_variance);
    tell_s_ += std::chrono::duration<double>(Clock::now() - start).count();
  }

  void Cancel(opt::CandidateId id) {
    const std::lock_guard lock(mutex_);
    optimizer_->Cancel(id);
  }

  /// (values, estimated value, observed value, id), or None before the first result.
  std::optional<std::tuple<std::vector<double>, double, double, opt::CandidateId>> Best() {
    const std::lock_guard lock(mutex_);
    const std::optional<opt::BestPoint> b = optimizer_->Best();
    if (!b) return std::nullopt;
    return std::make_tuple(std::vector<double>(b->x.data(), b->x.data() + b->x.size()), b->value,
                           b->observed, b->id);
  }

  std::string SaveState() {
    const std::lock_guard lock(mutex_);
    return optimizer_->SaveState().dump();
  }
  void RestoreState(const std::string& state) {
    const std::lock_guard lock(mutex_);
    optimizer_->RestoreState(nlohmann::json::parse(state));
  }

  /// The BayesOpt, or ValueError naming the call for the other methods.
  opt::BayesOpt& Bo(const char* call) {
    auto* bo = dynamic_cast<opt::BayesOpt*>(optimizer_.get());
    if (bo == nullptr) throw ConfigError("", call, "only Bayesian optimisation (BayesOpt) has it");
    return *bo;
  }
  void NotifyContextChanged() {
    const std::lock_guard lock(mutex_);
    Bo("notify_context_changed").NotifyContextChanged();
  }
  void AdvanceAge(double amount) {
    const std::lock_guard lock(mutex_);
    Bo("advance_age").AdvanceAge(amount);
  }
  /// Posterior (mean, variance) of the objective at x (space order).
  std::pair<double, double> Predict(const std::vector<double>& x) {
    const std::lock_guard lock(mutex_);
    double mean = 0.0;
    double variance = 0.0;
    Bo("predict").Predict(
        Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size())), &mean,
        &variance);
    return {mean, variance};
  }

  std::size_t NumTold() const { return optimizer_->NumTold(); }
  std::size_t NumPending() const { return optimizer_->NumPending(); }
  std::vector<std::string> Names() const { return space_.Names(); }
  std::vector<double> Defaults() const {
    const Eigen::VectorXd d = space_.Defaults();
    return {d.data(), d.data() + d.size()};
  }
  std::vector<bool> Integer() const {
    std::vector<bool> out;
    for (const opt::Parameter& p : space_.Parameters()) {
      out.push_back(p.type == opt::ParameterType::kInteger);
    }
    return out;
  }
  double AskSeconds() const { return ask_s_; }
  double TellSeconds() const { return tell_s_; }

 private:
  std::mutex mutex_;
  opt::ParameterSpace space_;
  std::unique_ptr<opt::Optimizer> optimizer_;
  double ask_s_ = 0.0;
  double tell_s_ = 0.0;
};

}  // namespace

void BindOptimizers(py::module_& m) {
  using Release = py::call_guard<py::gil_scoped_release>;
  py::class_<Optimizer>(m, "Optimizer",
                        "One of quadtune's ask/tell optimisers (quadtune.BayesOpt, PSO and "
                        "RandomSearch wrap it); minimises.")
      .def(py::init<const std::string&, const std::string&, const std::string&, std::uint64_t>(),
           py::arg("method"), py::arg("space_yaml"), py::arg("options_yaml"), py::arg("seed"))
      .def("ask", &Optimizer::Ask, py::arg("k") = 1, Release())
      .def("tell", &Optimizer::Tell, py::arg("id"), py::arg("value"),
           py::arg("noise_variance") = std::nullopt, Release())
      .def("cancel", &Optimizer::Cancel, py::arg("id"), Release())
      .def("best", &Optimizer::Best, Release())
      .def("save_state", &Optimizer::SaveState, Release())
      .def("restore_state", &Optimizer::RestoreState, py::arg("state"), Release())
      .def("notify_context_changed", &Optimizer::NotifyContextChanged, Release())
      .def("advance_age", &Optimizer::AdvanceAge, py::arg("amount") = 1.0, Release())
      .def("predict", &Optimizer::Predict, py::arg("x"), Release())
      .def_property_readonly("num_told", &Optimizer::NumTold)
      .def_property_readonly("num_pending", &Optimizer::NumPending)
      .def_property_readonly("names", &Optimizer::Names)
      .def_property_readonly("defaults", &Optimizer::Defaults)
      .def_property_readonly("integer", &Optimizer::Integer)
      .def_property_readonly("ask_seconds", &Optimizer::AskSeconds)
      .def_property_readonly("tell_seconds", &Optimizer::TellSeconds);
}

}  // namespace quadtune::python
