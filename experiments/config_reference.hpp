#pragma once
/// \file
/// The configuration reference (docs/config.md), written from the field lists of every options
/// struct (common/fields.hpp): the keys the readers accept are the keys the page lists, with
/// their types, defaults, ranges and meanings. `quadtune config-reference` prints it;
/// `--out docs/config.md` rewrites the page, and the test ConfigReference.DocsPageIsCurrent
/// fails when the page and the lists differ.

#include <CLI/CLI.hpp>
#include <string>

namespace quadtune::cli {

/// The whole page, Markdown.
[[nodiscard]] std::string ConfigReference();

/// `quadtune config-reference [--out FILE]`.
void RegisterConfigReference(CLI::App& app, int& exit_code);

}  // namespace quadtune::cli
