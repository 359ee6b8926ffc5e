// vlt/vlt.h — the whole public API of vlt in one include (docs/library.md). Each header can also be
// included alone; the order below reads from the vocabulary to the commands' work.
#pragma once

// Errors, units and quantities; distributions and coverage factors.
#include "vlt/error.h"
#include "vlt/units.h"
#include "vlt/input_file.h"
#include "vlt/distributions.h"
// The instrument: generated models, the measurement model of a point, readings from a point, air.
#include "vlt/model_info.h"
#include "vlt/models.h"
#include "vlt/measurement_model.h"
#include "vlt/inverse.h"
#include "vlt/refractive_index.h"
// Task quantities and their fits; conformity with a tolerance.
#include "vlt/fits.h"
#include "vlt/tasks.h"
#include "vlt/conformity.h"
// The engines: GUM propagation, Monte Carlo, validation of the one by the other.
#include "vlt/gum.h"
#include "vlt/mcm.h"
#include "vlt/validation.h"
// Jobs (tracker and custom-model), their results and files; the processes of an MPI run.
#include "vlt/job.h"
#include "vlt/custom_job.h"
#include "vlt/results.h"
#include "vlt/mpi.h"
// The commands' capabilities: calibration, networks, station planning.
#include "vlt/calibration.h"
#include "vlt/network.h"
#include "vlt/planning.h"
