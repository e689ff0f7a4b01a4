#include <spdlog/spdlog.h>

#include <string>

#include "commands.hpp"
#include "result_dir.hpp"
#include "quadtune/common/cancel.hpp"
#include "quadtune/layout/layout.hpp"

namespace quadtune::cli {
namespace {

struct LayoutArgs {
  std::string options_file;
  double spacing = 1.3;
  std::uint64_t seed = 1;
  std::string out = "layout.yaml";
};

int RunLayout(const LayoutArgs& a) {
  CheckOutputFile(a.out, "--out");
  layout::LayoutOptions options;
  if (!a.options_file.empty()) {
    options = layout::LayoutOptions::LoadFile(a.options_file);
  } else {
    options = ForestOptions(a.spacing);
  }
  InstallCancelSignalHandlers();  // SIGINT/SIGTERM stop the generator (it checks the flag)
  layout::Layout layout;
  try {
    layout = layout::GenerateLayout(options, a.seed);
    ThrowIfCancelled("layout generation");
  } catch (const Cancelled&) {
    spdlog::warn("layout generation interrupted; nothing written");
    return 130;
  }
  layout.Save(a.out);
  const auto& s = layout.stats.overall;
  spdlog::info("{} cylinders, {} rings (density: {}); mean nearest-neighbour spacing {:.3f} m "
               "(std {:.3f}, min {:.3f}); saved to {}",
               layout.obstacles.cylinders.size(), layout.obstacles.rings.size(),
               quadtune::ToString(options.density), s.mean, s.std, s.min, a.out);
  const auto zones = options.EffectiveZones();
  for (std::size_t i = 0; i < layout.stats.zones.size(); ++i) {
    const auto& z = layout.stats.zones[i];
    const std::string target =
        options.density == layout::DensityDefinition::kArea
            ? fmt::format("area target {:.0f}, ", options.TargetCount(zones[i]))
            : std::string();
    spdlog::info("  zone x in [{:.1f}, {:.1f}] m: spacing {:.2f} m, {} obstacles ({}{:.3f} per "
                 "m²), mean nearest-neighbour distance {:.3f} m, free gap mean {:.3f} m (std "
                 "{:.3f}, min {:.3f})",
                 z.x_min, z.x_max, z.target_spacing, z.cylinders + z.rings, target,
                 static_cast<double>(z.cylinders + z.rings) / options.ZoneArea(zones[i]),
                 z.spacing.mean, z.gap.mean, z.gap.std, z.gap.min);
  }
  return 0;
}

}  // namespace

void RegisterLayout(CLI::App& app, int& exit_code) {
  static LayoutArgs args;
  auto* cmd = app.add_subcommand("layout", "generate an obstacle layout (CGAL) and save it");
  cmd->add_option("--layout-options", args.options_file,
                  "layout generator options (YAML) to generate from");
  cmd->add_option("--options", args.options_file)->group("");  // an accepted alias, not shown in help
  cmd->add_option("--spacing", args.spacing, "average spacing (m) without --layout-options: the "
                                             "shipped forest of that spacing, else forest_1p3")
      ->capture_default_str();
  cmd->add_option("--seed", args.seed, "seed")->capture_default_str()->check(SeedValidator());
  cmd->add_option("--out", args.out, "output file (YAML)")->capture_default_str();
  cmd->callback([&exit_code] { exit_code = RunLayout(args); });
}

}  // namespace quadtune::cli
