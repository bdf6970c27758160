// granflow: run a scene (a Teuchos ParameterList XML file) to its end time.
//
//   granflow <scene.xml>          run the scene
//   granflow --check <scene.xml>  validate the scene only
//   granflow --parameters         print the parameter reference (docs/parameters.md)
//   granflow --help
#include "granflow/core/simulation.hpp"
#include "granflow/params/parameters.hpp"
#include "granflow/scene/scene.hpp"

#include <Teuchos_GlobalMPISession.hpp>

#include <iostream>
#include <sstream>
#include <string>

namespace {
void usage(std::ostream& os) {
  os << "usage: granflow [--check] <scene.xml>\n"
        "       granflow --parameters\n"
        "       granflow --help\n\n"
        "Runs a granular-flow scene written as a Teuchos ParameterList XML file (see inputs/ and\n"
        "docs/parameters.md) and writes profiles.csv, fields.h5 + fields.xdmf, checkpoint.h5 and\n"
        "summary.json into the scene's 'Output->Directory'.\n\n"
        "options:\n"
        "  --check       validate the scene and exit (0 if valid)\n"
        "  --parameters  print the full parameter reference (Markdown) generated from the code\n"
        "  --help        this text\n\n"
        "exit codes: 0 completed, 1 usage, 2 invalid input, 3 diverged (last good output and\n"
        "checkpoint kept), 4 runtime error, 5 step limit reached\n";
}
}  // namespace

int main(int argc, char** argv) {
  using namespace granflow;
  // 1. MPI: Debian's Trilinos is built on OpenMPI; the 2D solvers run on the run's communicator.
  Teuchos::GlobalMPISession mpi(&argc, &argv, nullptr);

  // Messages go to the terminal from rank 0 only (every rank runs this main under mpiexec).
  const bool root = mpi.getRank() == 0;
  std::ostringstream sink;
  std::ostream& out = root ? std::cout : sink;
  std::ostream& err = root ? std::cerr : sink;

  // 2. Command line. Every argument is read before anything is done, so that an unknown or
  // extra one is a usage error (exit 1) whatever comes first: "--help --bogus" and
  // "--parameters extra" must not succeed quietly.
  std::string file;
  bool check_only = false, help = false, reference = false;
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
    // 4. Build only what the scene's model uses, with its initial state.
    auto model = scene::build_model(s);
    const auto rc = core::RunControl::from_parameters(s.params->sublist("Time"),
                                                      s.params->sublist("Output"), s.dir);
    if (check_only) {
      out << file << ": valid scene '" << s.name << "' (model " << s.model << ")\n";
      return core::kOk;
    }
    out << "granflow: scene '" << s.name << "', model " << s.model << ", to t = "
              << rc.end_time << " s, output in " << rc.directory << "\n";
    // 5. Run to the end time.
    core::Simulation sim(s.name, *s.params, std::move(model), rc);
    const int code = sim.run();
    const auto mb = sim.model().mass_balance();
    out << "granflow: " << (code == core::kOk ? "completed" : "stopped") << " at t = "
              << sim.model().time() << " s after " << sim.model().steps()
              << " steps; mass defect " << mb.defect() << " m^2 (initial " << mb.initial
              << ", final " << mb.current << ")\n";
    return code;
  } catch (const params::InputError& e) {
    err << "granflow: invalid input: " << e.what() << "\n";
    return core::kInputError;
  } catch (const std::exception& e) {
    err << "granflow: error: " << e.what() << "\n";
    return core::kRuntimeError;
  }
}
