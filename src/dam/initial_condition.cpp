#include "granflow/dam/initial_condition.hpp"

#include "granflow/core/material.hpp"
#include "granflow/params/parameters.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace granflow::dam {

using Type = InitialCondition::Type;

namespace {
const std::vector<Type> kTypes{Type::Dry, Type::Uniform, Type::DamBreak, Type::Block,
                               Type::SineWave};

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

const char* to_string(Type t) {
  switch (t) {
    case Type::Dry: return "Dry";
    case Type::Uniform: return "Uniform";
    case Type::DamBreak: return "Dam break";
    case Type::Block: return "Block";
    case Type::SineWave: return "Sine wave";
  }
  return "?";
}

Teuchos::RCP<const Teuchos::ParameterList> InitialCondition::getValidParameters() {
  static Teuchos::RCP<const Teuchos::ParameterList> valid = [] {
    using namespace params;
    auto pl = Teuchos::rcp(new Teuchos::ParameterList("Initial condition"));
    const InitialCondition d;
    std::vector<std::string> names;
    for (Type t : kTypes) names.emplace_back(to_string(t));
    add_enum(*pl, "Type", to_string(d.type),
             "Dry: empty channel; Uniform: h = Depth, u = Velocity everywhere; Dam break: "
             "Left depth for x < Position, Right depth beyond, at rest; Block: Depth and Velocity "
             "on [Start, End], dry elsewhere; Sine wave: h = Depth (1 + Amplitude sin(2 pi "
             "Wavenumber x / L)), u = Velocity",
             names);
    add_double(*pl, "Depth", d.depth, "[m] layer depth (Uniform, Block, Sine wave)", 0.0, 1e3);
    add_double(*pl, "Velocity", d.velocity,
               "[m/s] initial velocity (Uniform, Block, Sine wave, Dam break)", -1e3, 1e3);
    add_double(*pl, "Left depth", d.left_depth, "[m] depth upstream of the dam (Dam break)", 0.0,
               1e3);
    add_double(*pl, "Right depth", d.right_depth, "[m] depth downstream of the dam (Dam break)",
               0.0, 1e3);
    add_double(*pl, "Position", d.position, "[m] dam position along the channel (Dam break)",
               -1e6, 1e6);
    add_double(*pl, "Start", d.start, "[m] upstream end of the block (Block)", -1e6, 1e6);
    add_double(*pl, "End", d.end, "[m] downstream end of the block (Block)", -1e6, 1e6);
    add_double(*pl, "Amplitude", d.amplitude, "relative amplitude of the sine wave (Sine wave)",
               0.0, 0.99);
    add_int(*pl, "Wavenumber", d.wavenumber, "number of wavelengths on the channel (Sine wave)",
            1, 1000000);
    return pl;
  }();
  return valid;
}

InitialCondition InitialCondition::from_parameters(const Teuchos::ParameterList& pl,
                                                   const Teuchos::ParameterList* user,
                                                   const core::Channel& ch) {
  const auto type = pl.get<std::string>("Type");
  params::fail_unused(pl, user, used_by_type().at(type), "Type",
                      "initial condition Type '" + type + "'");
  InitialCondition c;
  for (Type t : kTypes)
    if (type == to_string(t)) c.type = t;
  c.depth = pl.get<double>("Depth");
  c.velocity = pl.get<double>("Velocity");
  c.left_depth = pl.get<double>("Left depth");
  c.right_depth = pl.get<double>("Right depth");
  c.position = pl.get<double>("Position");
  c.start = pl.get<double>("Start");
  c.end = pl.get<double>("End");
  c.amplitude = pl.get<double>("Amplitude");
  c.wavenumber = pl.get<int>("Wavenumber");
  auto in_channel = [&](const char* name, double x) {
    if (x < 0.0 || x > ch.length)
      params::fail(pl, name, params::str(x),
                   "outside the channel; allowed: [0, " + params::str(ch.length) + "]");
  };
  if (c.type == Type::DamBreak) in_channel("Position", c.position);
  if (c.type == Type::Block) {
    in_channel("Start", c.start);
    in_channel("End", c.end);
    if (c.end <= c.start)
      params::fail(pl, "End", params::str(c.end),
                   "must be greater than 'Start' = " + params::str(c.start));
  }
  return c;
}

void InitialCondition::apply(const core::Channel& ch, DamSolver& dam) const {
  const double L = ch.length;
  switch (type) {
    case Type::Dry:
      dam.set_state([](double) { return 0.0; }, [](double) { return 0.0; });
      break;
    case Type::Uniform: {
      const double h0 = depth, u0 = velocity;
      dam.set_state([h0](double) { return h0; }, [u0](double) { return u0; });
      break;
    }
    case Type::DamBreak: {
      const double hl = left_depth, hr = right_depth, x0 = position, u0 = velocity;
      dam.set_state([=](double x) { return x < x0 ? hl : hr; }, [u0](double) { return u0; }, 0.0,
                    {x0});
      break;
    }
    case Type::Block: {
      const double a = start, b = end, h0 = depth, u0 = velocity;
      dam.set_state([=](double x) { return (x >= a && x <= b) ? h0 : 0.0; },
                    [=](double x) { return (x >= a && x <= b) ? u0 : 0.0; }, 0.0, {a, b});
      break;
    }
    case Type::SineWave: {
      const double h0 = depth, u0 = velocity, a = amplitude;
      const int k = wavenumber;
      dam.set_state(
          [=](double x) { return h0 * (1.0 + a * std::sin(2.0 * core::kPi * k * x / L)); },
          [u0](double) { return u0; });
      break;
    }
  }
}

void InitialCondition::apply(const Teuchos::ParameterList& validated,
                             const Teuchos::ParameterList* user, const core::Channel& channel,
                             DamSolver& dam) {
  from_parameters(validated, user, channel).apply(channel, dam);
}

}  // namespace granflow::dam
