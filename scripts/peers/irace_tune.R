#!/usr/bin/Rscript
# irace (Debian: r-cran-irace) tuning an experiment's parameter box with its flight budget: the
# instances are the repeat's tuning maps (instance k flies tuning map k, as quadtune's methods
# do), every experiment is one flight through `quadtune evaluate`, and the recommendation is
# irace's best elite configuration.
#
#   Rscript scripts/peers/irace_tune.R EXPERIMENT REPEAT BUDGET SEED OUT.json BOX.tsv [KEY=VALUE…]
#
# Each KEY=VALUE after BOX.tsv changes the experiment for every flight (`quadtune evaluate --set`).
# BOX.tsv (written by scripts/peers/peers.py): name, lower, upper, log, integer, one row each.
suppressPackageStartupMessages(library(irace))

args <- commandArgs(trailingOnly = TRUE)
experiment <- args[1]
repeat_index <- as.integer(args[2])
budget <- as.integer(args[3])
seed <- as.integer(args[4])
out <- args[5]
box <- read.delim(args[6], stringsAsFactors = FALSE)
sets <- if (length(args) > 6) args[7:length(args)] else character(0)
set_flags <- as.vector(rbind(rep("--set", length(sets)), sets))
quadtune <- Sys.getenv("QUADTUNE", "build/experiments/quadtune")

lines <- sprintf("%s \"\" %s (%s, %s)", box$name,
                 ifelse(box$integer == 1, "i", ifelse(box$log == 1, "r,log", "r")),
                 box$lower, box$upper)
parameters <- readParameters(text = paste(lines, collapse = "\n"))

fly <- function(experiment_row, scenario) {
  conf <- experiment_row$configuration
  flags <- unlist(lapply(names(conf), function(n) c("--param", sprintf("%s=%.17g", n, as.numeric(conf[[n]])))))
  cmd_args <- c("--log-level", "warn", "evaluate", experiment, "--maps", "tuning",
                "--first", as.character(experiment_row$instance), "--count", "1",
                "--repeat", as.character(repeat_index), "--threads", "1", set_flags, flags)
  text <- system2(quadtune, cmd_args, stdout = TRUE)
  rows <- read.csv(text = text)
  list(cost = rows$value[1])
}

# Two races of configurations where the budget holds them (irace asks about 70 experiments for
# two with six parameters), one below 100 flights; IRACE_ITERATIONS overrides.
iterations <- as.integer(Sys.getenv("IRACE_ITERATIONS", if (budget >= 100) "2" else "1"))
scenario <- list(targetRunner = fly, instances = seq(0, budget - 1), maxExperiments = budget,
                 seed = seed, logFile = "", quiet = TRUE, deterministic = TRUE,
                 firstTest = as.integer(Sys.getenv("IRACE_FIRST_TEST", "5")),
                 nbIterations = iterations)
elites <- irace(scenario = scenario, parameters = parameters)
best <- elites[1, box$name, drop = FALSE]
point <- lapply(box$name, function(n) as.numeric(best[[n]]))
names(point) <- box$name
json <- sprintf("{\"tuner\": \"irace\", \"repeat\": %d, \"flights\": %d, \"params\": {%s}}",
                repeat_index, budget,
                paste(sprintf("\"%s\": %.17g", names(point), unlist(point)), collapse = ", "))
writeLines(json, out)
cat(json, "\n")
