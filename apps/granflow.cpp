// granflow: run a scene (a Teuchos ParameterList XML file) to its end time.
//
//   granflow [--overwrite] <scene.xml>  run the scene
//   granflow --check <scene.xml>        validate the scene only
//   granflow --parameters         print the parameter reference (docs/parameters.md)
//   granflow --help
#include "build_info.hpp"
#include "granflow/core/simulation.hpp"
#include "granflow/params/parameters.hpp"
#include "granflow/scene/memory.hpp"
#include "granflow/scene/scene.hpp"

#include <malloc.h>
#include <Teuchos_GlobalMPISession.hpp>

#include <mpi.h>

#include <cstdio>
#include <iostream>
#include <new>
#include <sstream>
#include <string>

namespace {
void usage(std::ostream& os) {
  os << "usage: granflow [--check] [--overwrite] <scene.xml>\n"
        "       granflow --parameters\n"
        "       granflow --help\n\n"
        "Runs a granular-flow scene written as a Teuchos ParameterList XML file (see inputs/ and\n"
        "docs/parameters.md) and writes profiles.csv, fields.h5 + fields.xdmf (snapshots in\n"
        "fields.h5.d/), checkpoint.h5, wall.csv (channels with a wall end), summary.json and\n"
        "run.json into the scene's 'Output->Directory'. A run owns that\n"
        "directory: a rerun of the same scene replaces its files; another scene's files there\n"
        "stop the run (exit 2) unless --overwrite is given.\n\n"
        "options:\n"
        "  --check       validate the scene, its restart checkpoint, its memory need and its\n"
        "                run directory, and exit (0 if valid)\n"
        "  --overwrite   replace the files of another scene's run in the run directory\n"
        "  --parameters  print the full parameter reference (Markdown) generated from the code\n"
        "  --help        this text\n\n"
        "SIGINT (Ctrl-C), SIGTERM or SIGHUP (unless ignored, as under nohup) ends the step in\n"
        "progress, writes checkpoint.h5 of the last\n"
        "accepted state and summary.json with status \"interrupted\"; a second signal ends the\n"
        "run at once (one line says so; no checkpoint of that step).\n\n"
        "exit codes: 0 completed, 1 usage, 2 invalid input, 3 diverged (last good output and\n"
        "checkpoint kept), 4 runtime error, 5 step limit reached, 128 + signal when interrupted\n"
        "(130 SIGINT, 143 SIGTERM, 129 SIGHUP)\n";
}
}  // namespace

int main(int argc, char** argv) {
  using namespace granflow;
  // 0. Memory: the solvers build their matrices anew at every change of the sparsity pattern
  // (every step of a free-surface run), in blocks of 0.1-1 MB. glibc's thresholds adapt to the
  // blocks freed (mmap: raised to the largest one; trimming with it), so such blocks move from
  // mapped memory to the heap in the middle of a run and the resident set grows in a step
  // (cli.memory_steady_run: +1.0 %, a step of 0.47 MB at t = 4.2 s of a steady run). Fixed
  // thresholds keep every block below 32 MB on the heap from the start and the heap untrimmed
  // below 64 MB: +0.67 %, no step, and the same speed (Setup II 2.6 mm: 1.01x, median of 3
  // pairs; a 128 kB mmap threshold instead was 1.14x slower, page faults of fresh mappings).
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 64 << 20);
  // 1. MPI: Debian's Trilinos is built on OpenMPI; the 2D solvers run on the run's communicator.
  Teuchos::GlobalMPISession mpi(&argc, &argv, nullptr);
  // Logs: a redirected stdout is block-buffered by default, so a log file stayed empty while
  // the run went on; line buffering shows each message when it is written (stderr is
  // unbuffered already).
  std::setvbuf(stdout, nullptr, _IOLBF, BUFSIZ);

  // Messages go to the terminal from rank 0 only (every rank runs this main under mpiexec).
  const bool root = mpi.getRank() == 0;
  std::ostringstream sink;
  std::ostream& out = root ? std::cout : sink;
  std::ostream& err = root ? std::cerr : sink;

  // 2. Command line. Every argument is read before anything is done, so that an unknown or
  // extra one is a usage error (exit 1) whatever comes first: "--help --bogus" and
  // "--parameters extra" must not succeed quietly.
  std::string file;
  bool check_only = false, help = false, reference = false, overwrite = false;
  int others = 0;  // arguments other than --help / --parameters
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      help = true;
    } else if (a == "--parameters") {
      reference = true;
    } else if (a == "--check") {
      check_only = true;
      ++others;
    } else if (a == "--overwrite") {
      overwrite = true;
      ++others;
    } else if (!a.empty() && a[0] == '-') {
      const std::string shown = params::shown(a);  // "..." with unprintable bytes as \xNN
      err << "granflow: unknown option '" << shown.substr(1, shown.size() - 2) << "'\n";
      usage(err);
      return core::kUsage;
    } else if (file.empty()) {
      file = a;
      ++others;
    } else {
      err << "granflow: more than one scene file given ('" << file << "', '" << a << "')\n";
      return core::kUsage;
    }
  }
  if (help || reference) {
    if (help + reference + others != 1) {
      err << "granflow: " << (help ? "--help" : "--parameters")
          << " takes no other argument\n";
      usage(err);
      return core::kUsage;
    }
    if (help) usage(out);
    else out << scene::parameter_reference();
    return core::kOk;
  }
  if (file.empty()) {
    usage(err);
    return core::kUsage;
  }

  try {
    // 3. Read and validate the scene; inconsistent input stops here.
    const scene::Scene s = scene::load(file);
    auto rc = core::RunControl::from_parameters(s.params->sublist("Time"),
                                                s.params->sublist("Output"), s.dir);
    rc.overwrite = overwrite;
    rc.energy_bound = scene::energy_speed_bound(s);
    // 4. Memory: estimate before anything is allocated (the ranks on this node share it).
    MPI_Comm node;
    MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
    int node_ranks = 1;
    MPI_Comm_size(node, &node_ranks);
    MPI_Comm_free(&node);
    const auto memory = scene::estimate_memory(s, mpi.getNProc(), node_ranks);
    scene::check_memory(s, memory, scene::machine_memory());
    // 5. The restart checkpoint and the run directory (before the model is built).
    core::preflight(*s.params, rc);
    // 6. Build only what the scene's model uses, with its initial state (a signal from here on
    //    stops the run before its first step, with a checkpoint and a summary).
    if (!check_only) core::catch_interrupts();
    auto model = scene::build_model(s);
    if (check_only) {
      out << file << ": valid scene '" << s.name << "' (model " << s.model
          << "; memory estimate " << scene::format_bytes(memory.bytes) << ")\n";
      return core::kOk;
    }
    out << "granflow: scene '" << s.name << "', model " << s.model << ", to t = "
              << rc.end_time << " s, output in " << rc.directory << "\n";
    // 7. Run to the end time.
    core::Simulation sim(s.name, *s.params, std::move(model), rc);
    sim.set_build_info(granflow_build_info());
    sim.set_memory_estimate(memory.bytes);
    const int code = sim.run();
    const auto mb = sim.final_mass_balance();
    out << "granflow: " << (code == core::kOk ? "completed" : "stopped") << " at t = "
              << sim.final_time() << " s after " << sim.final_steps()
              << " steps; mass defect " << mb.defect() << " m^2 (initial " << mb.initial
              << ", final " << mb.current << ")\n";
    return code;
  } catch (const params::InputError& e) {
    // every input error names the scene file (the checks after loading it, such as the
    // restart's, did not: an independent run)
    std::string what = e.what();
    if (what.rfind(file, 0) != 0) what = file + ": " + what;
    err << "granflow: invalid input: " << what << "\n";
    return core::kInputError;
  } catch (const std::bad_alloc&) {
    err << "granflow: error: out of memory (std::bad_alloc); see 'memory estimate' of "
           "granflow --check for what the scene needs\n";
    return core::kRuntimeError;
  } catch (const std::exception& e) {
    err << "granflow: error: " << e.what() << "\n";
    return core::kRuntimeError;
  }
}
