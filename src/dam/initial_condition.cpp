#include "granflow/dam/initial_condition.hpp"

#include "granflow/core/material.hpp"
#include "granflow/params/parameters.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace granflow::dam {

namespace {
// Which parameters each type reads; any other one given by the user is an error.
const std::map<std::string, std::vector<std::string>>& used_by_type() {
  static const std::map<std::string, std::vector<std::string>> m{
      {"Dry", {}},
      {"Uniform", {"Depth", "Velocity"}},
      {"Dam break", {"Left depth", "Right depth", "Position", "Velocity"}},
      {"Block", {"Depth", "Velocity", "Start", "End"}},
      {"Sine wave", {"Depth", "Velocity", "Amplitude", "Wavenumber"}}};
  return m;
}
}  // namespace

Teuchos::RCP<const Teuchos::ParameterList> InitialCondition::getValidParameters() {
  static Teuchos::RCP<const Teuchos::ParameterList> valid = [] {
    using namespace params;
    auto pl = Teuchos::rcp(new Teuchos::ParameterList("Initial condition"));
    add_enum(*pl, "Type", "Dry",
             "Dry: empty channel; Uniform: h = Depth, u = Velocity everywhere; Dam break: "
             "Left depth for x < Position, Right depth beyond, at rest; Block: Depth and Velocity "
             "on [Start, End], dry elsewhere; Sine wave: h = Depth (1 + Amplitude sin(2 pi "
             "Wavenumber x / L)), u = Velocity",
             {"Dry", "Uniform", "Dam break", "Block", "Sine wave"});
    add_double(*pl, "Depth", 0.05, "[m] layer depth (Uniform, Block, Sine wave)", 0.0, 1e3);
    add_double(*pl, "Velocity", 0.0, "[m/s] initial velocity (Uniform, Block, Sine wave, Dam break)",
               -1e3, 1e3);
    add_double(*pl, "Left depth", 0.1, "[m] depth upstream of the dam (Dam break)", 0.0, 1e3);
    add_double(*pl, "Right depth", 0.0, "[m] depth downstream of the dam (Dam break)", 0.0, 1e3);
    add_double(*pl, "Position", 0.5, "[m] dam position along the channel (Dam break)", -1e6, 1e6);
    add_double(*pl, "Start", 0.0, "[m] upstream end of the block (Block)", -1e6, 1e6);
    add_double(*pl, "End", 0.1, "[m] downstream end of the block (Block)", -1e6, 1e6);
    add_double(*pl, "Amplitude", 0.1, "relative amplitude of the sine wave (Sine wave)", 0.0, 0.99);
    add_int(*pl, "Wavenumber", 1, "number of wavelengths on the channel (Sine wave)", 1, 1000000);
    return pl;
  }();
  return valid;
}

void InitialCondition::apply(const Teuchos::ParameterList& pl, const Teuchos::ParameterList* user,
                             const core::Channel& ch, DamSolver& dam) {
  const auto type = pl.get<std::string>("Type");
  const auto& used = used_by_type().at(type);
  if (user) {
    for (auto it = user->begin(); it != user->end(); ++it) {
      const auto& n = user->name(it);
      if (n == "Type") continue;
      if (std::find(used.begin(), used.end(), n) == used.end()) {
        std::string allowed;
        for (const auto& u : used) allowed += (allowed.empty() ? "" : ", ") + u;
        params::fail(pl, n, Teuchos::toString(user->entry(it).getAny(false)),
                     "not used by initial condition Type '" + type + "' (it reads: " +
                         (allowed.empty() ? std::string("nothing") : allowed) + ")");
      }
    }
  }
  auto in_channel = [&](const char* name) {
    const double x = pl.get<double>(name);
    if (x < 0.0 || x > ch.length)
      params::fail(pl, name, params::str(x),
                   "outside the channel; allowed: [0, " + params::str(ch.length) + "]");
    return x;
  };
  const double L = ch.length;
  if (type == "Dry") {
    dam.set_state([](double) { return 0.0; }, [](double) { return 0.0; });
  } else if (type == "Uniform") {
    const double h0 = pl.get<double>("Depth"), u0 = pl.get<double>("Velocity");
    dam.set_state([h0](double) { return h0; }, [u0](double) { return u0; });
  } else if (type == "Dam break") {
    const double hl = pl.get<double>("Left depth"), hr = pl.get<double>("Right depth");
    const double x0 = in_channel("Position"), u0 = pl.get<double>("Velocity");
    dam.set_state([=](double x) { return x < x0 ? hl : hr; }, [u0](double) { return u0; });
  } else if (type == "Block") {
    const double a = in_channel("Start"), b = in_channel("End");
    if (b <= a)
      params::fail(pl, "End", params::str(b),
                   "must be greater than 'Start' = " + params::str(a));
    const double h0 = pl.get<double>("Depth"), u0 = pl.get<double>("Velocity");
    dam.set_state([=](double x) { return (x >= a && x <= b) ? h0 : 0.0; },
                  [=](double x) { return (x >= a && x <= b) ? u0 : 0.0; });
  } else {  // Sine wave
    const double h0 = pl.get<double>("Depth"), u0 = pl.get<double>("Velocity");
    const double a = pl.get<double>("Amplitude");
    const int k = pl.get<int>("Wavenumber");
    dam.set_state([=](double x) { return h0 * (1.0 + a * std::sin(2.0 * core::kPi * k * x / L)); },
                  [u0](double) { return u0; });
  }
}

}  // namespace granflow::dam
