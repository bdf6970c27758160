#include "granflow/coupling/coupled_model.hpp"

#include "granflow/coupling/conversion.hpp"
#include "granflow/coupling/domain_manager.hpp"
#include "granflow/coupling/factory.hpp"

#include "granflow/io/fields.hpp"
#include "granflow/params/parameters.hpp"

#include <Teuchos_StandardParameterEntryValidators.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace granflow::coupling {

// ---------------------------------------------------------------------------------------------
// Decomposition parameters
// ---------------------------------------------------------------------------------------------
Teuchos::RCP<const Teuchos::ParameterList> Decomposition::getValidParameters() {
  static Teuchos::RCP<const Teuchos::ParameterList> valid = [] {
    using namespace params;
    const Decomposition d;  // the defaults
    auto pl = Teuchos::rcp(new Teuchos::ParameterList("Decomposition"));
    add_enum(*pl, "Layout", d.layout,
             "Static: the subdomains of 'Models' split at 'Interfaces'; A priori: a DAM run of "
             "the whole scene first computes eps = 1/Fr^2 and the model is 2D wherever "
             "eps >= 'Shallowness threshold' (plus 'Margin'), 1D elsewhere (paper section 4.1); "
             "Dynamic: the domain manager moves the interfaces while the run goes on, starting "
             "from 'Initial layout' (docs/numerics.md, 'Domain manager')",
             {"Static", "A priori", "Dynamic"});
    auto kinds = Teuchos::rcp(new Teuchos::StringValidator(Teuchos::tuple<std::string>("1D", "2D")));
    pl->set("Models", Teuchos::Array<std::string>(d.models.begin(), d.models.end()),
            "model of each subdomain from upstream to downstream: 1D (DAM) or 2D (N-DAM); one "
            "more entry than 'Interfaces' (Static layout, and a Dynamic one that starts from it)",
            Teuchos::rcp(new Teuchos::ArrayStringValidator(kinds)));
    auto pos = Teuchos::rcp(new Teuchos::EnhancedNumberValidator<double>(0.0, 1e6));
    pl->set("Interfaces", Teuchos::Array<double>(d.interfaces.begin(), d.interfaces.end()),
            "[m] interface positions, non-decreasing in [0, L] (Static layout); the paper's "
            "Setup I/II layout is {0.2, 0.7}. A subdomain of zero length (equal neighbouring "
            "positions, or a position at 0 or L) is left out and same-model neighbours that then "
            "touch become one subdomain: {2D, 1D, 2D} with {a, a} is the full 2D model",
            Teuchos::rcp(new Teuchos::ArrayNumberValidator<double>(pos)));
    add_double(*pl, "Shallowness threshold", d.eps_threshold,
               "A priori and Dynamic layouts: 2D wherever the shallowness parameter eps reaches "
               "this (a priori: eps = 1/Fr^2 at any output time of the DAM run; dynamic: at a "
               "check, see 'Lower threshold'). The paper's minimum requirement at an interface "
               "is eps < 0.1",
               1e-6, 1e6);
    add_double(*pl, "Margin", d.margin,
               "[m] each 2D region is widened by this on both sides (the paper: 'somewhat greater "
               "than suggested by the one-dimensional simulation'); in a Dynamic layout also how "
               "far inside 2D a shock or a rise of eps is kept, at least two slots there (the "
               "DAM's two ghost cells at an interface read the 2D side)",
               0.0, 1e6);
    add_double(*pl, "Minimum length", d.min_length,
               "[m] A priori and Dynamic layouts: shorter 1D gaps and end pieces become 2D, and a "
               "2D subdomain is never made shorter than this. Dynamic: at least four slots (the "
               "coarser of a 2D column and a 1D cell), checked when the model is built; a 2D "
               "subdomain gives back calm columns only while it keeps this length of material "
               "(a front that has just entered it keeps the layer behind it)",
               0.0, 1e6);
    add_enum(*pl, "Initial layout", d.initial_layout,
             "Dynamic layout: where the run starts: Static ('Models' and 'Interfaces', e.g. the "
             "paper's layout) or A priori (the layout of a DAM run, as Layout = A priori)",
             {"Static", "A priori"});
    add_double(*pl, "Lower threshold", d.eps_lower,
               "Dynamic layout: a 2D column may become 1D only where eps stays below this for "
               "'Hold time' (hysteresis between this and 'Shallowness threshold', so that "
               "interfaces do not flicker); must be below 'Shallowness threshold'. A band "
               "narrower than the indicator's noise (eps scatters by a few per cent in steady "
               "flow with the markers' depth) lets an interface flicker: a column given back "
               "to the 1D model for the third time within twenty 'Hold time's is warned of "
               "and counted (summary.json: domain_manager.flickers)",
               0.0, 1e6);
    add_double(*pl, "Hold time", d.hold_time,
               "[s] Dynamic layout: how long eps must stay below 'Lower threshold' before a 2D "
               "column becomes 1D; at least 'Check interval'",
               0.0, 1e6);
    add_double(*pl, "Check interval", d.check_interval,
               "[s] Dynamic layout: the longest time between two evaluations of the layout (at "
               "the end of the first accepted step at or after each multiple); a check comes "
               "earlier when a wave or shock could cross the margin before it: after at most "
               "max(Margin, one slot) / max(|u_mean| + sqrt(g cos(zeta) K_act h)) of the "
               "channel at the last check and of the gate's fastest and deepest inflow "
               "(summary.json: checks_brought_forward)",
               1e-9, 1e6);
    add_double(*pl, "Rest speed", d.rest_speed,
               "[m/s] Dynamic layout: material moving slower than this (|u_mean|) is at rest: a "
               "deposit, which stays 2D (eps = |w|/|u| is 0/0 there and 1/Fr^2 infinite)",
               0.0, 1e6);
    add_bool(*pl, "Shock indicator", d.shock_indicator,
             "Dynamic layout: a shock on the 1D side (u_mean drops across a column by more "
             "than the wave speed sqrt(beta h), to less than half its upstream value) counts as "
             "2D whatever its eps (false: eps and rest alone decide)");
    add_bool(*pl, "Deceleration indicator", d.deceleration_indicator,
             "Dynamic layout: where a 2D subdomain's depth-averaged flow slows by more than "
             "2 % and deepens by more than 2 % (the means of u_mean and h over a fifth of "
             "'Margin', at least two slots, on either side of a slot, at least two slots "
             "inside the subdomain) on a slope that accelerates a sliding layer (tan(zeta) > tan(delta)), "
             "the slot counts as 2D: the upstream reach of a shock, where the 2D pressure "
             "slows a supercritical flow that the DAM, which takes no information from "
             "downstream there, carries on unslowed (a 42 deg chute: u_mean 6.8 % off full 2D "
             "at 2.5 mm without it; docs/validation.md) (false: eps, rest and shocks alone "
             "decide)");
    add_bool(*pl, "Sub-cycling", d.subcycling,
             "the 1D subdomains take their own stable steps inside the common step of the 2D "
             "ones (false: one common step for all, the smallest stable step of any subdomain); "
             "the 1D-to-2D interface still passes exactly the DAM's mass of the whole step");
    add_double(*pl, "Interface mass relaxation", d.interface_mass_relaxation,
               "[s] an interface into a DAM (2D -> 1D, 1D | 1D): the DAM's own scheme takes in "
               "what its flux from the ghost cells says, the upstream side lets out what it "
               "counts (the 2D side: the markers that left); the difference is carried and "
               "handed to the DAM's first cells, the fraction dt / this of it after every step "
               "(0: all of it after every step), so that the coupled model's mass balance closes "
               "to round-off (docs/numerics.md, 'Mass, 2D -> 1D'); at most 1 s: a slower hand-over "
               "lets the DAM hold for the whole run mass that the 2D side still counts (a shipped "
               "scene with 1e6 s held 3 % of its mass as carried)",
               0.0, 1.0);
    add_enum(*pl, "Interface pressure", d.interface_pressure,
             "how the pressure of eq. (26), p = g cos(zeta)(h - z)(1 + K_act)/2, enters the first "
             "2D column behind a 1D-to-2D interface: Rheology: the column stays in the "
             "projection (div u = 0) and eq. (26) is the pressure of its yield stress; Dirichlet: "
             "the paper's literal reading, eq. (26) imposed as the column's pressure (continuity "
             "is then not enforced there, and the 2D flow behind the interface is measured 5 to "
             "10 % too slow, docs/validation.md); None: the column's pressure is solved and "
             "eq. (26) is not used",
             {"Rheology", "Dirichlet", "None"});
    return pl;
  }();
  return valid;
}

Decomposition Decomposition::from_parameters(const Teuchos::ParameterList& pl,
                                             const core::Channel& channel,
                                             const Teuchos::ParameterList* user) {
  Decomposition d;
  d.layout = pl.get<std::string>("Layout");
  const auto models = pl.get<Teuchos::Array<std::string>>("Models");
  const auto ifs = pl.get<Teuchos::Array<double>>("Interfaces");
  d.models.assign(models.begin(), models.end());
  d.interfaces.assign(ifs.begin(), ifs.end());
  d.eps_threshold = pl.get<double>("Shallowness threshold");
  d.margin = pl.get<double>("Margin");
  d.min_length = pl.get<double>("Minimum length");
  d.interface_pressure = pl.get<std::string>("Interface pressure");
  d.initial_layout = pl.get<std::string>("Initial layout");
  d.eps_lower = pl.get<double>("Lower threshold");
  d.hold_time = pl.get<double>("Hold time");
  d.check_interval = pl.get<double>("Check interval");
  d.rest_speed = pl.get<double>("Rest speed");
  d.shock_indicator = pl.get<bool>("Shock indicator");
  d.deceleration_indicator = pl.get<bool>("Deceleration indicator");
  d.subcycling = pl.get<bool>("Sub-cycling");
  d.interface_mass_relaxation = pl.get<double>("Interface mass relaxation");
  // A setting of another layout is refused by name, as the 2D model's unused options are: an
  // independent run found a Static layout taking 'Lower threshold' 0.5 (above the upper one),
  // 'Hold time' 0 and 'Rest speed' 100 without a word, and an A priori one its 'Models'.
  auto unused = [&](const char* name, const std::string& why) {
    params::fail_if_given(pl, user, name, why);
  };
  const bool dynamic = d.layout == "Dynamic";
  if (!dynamic)
    for (const char* name : {"Initial layout", "Lower threshold", "Hold time", "Check interval",
                             "Rest speed", "Shock indicator", "Deceleration indicator"})
      unused(name, "a setting of the domain manager, and 'Layout' = " + d.layout +
                       "; allowed: leave it out, or 'Layout' = Dynamic");
  if (d.layout == "Static")
    for (const char* name : {"Shallowness threshold", "Margin", "Minimum length"})
      unused(name, "a setting of the A priori and Dynamic layouts, and 'Layout' = Static; "
                   "allowed: leave it out, or 'Layout' = A priori or Dynamic");
  if (d.layout == "A priori" || (dynamic && d.initial_layout == "A priori"))
    for (const char* name : {"Models", "Interfaces"})
      unused(name, "the a priori layout replaces them with the layout of a DAM run; allowed: "
                   "leave it out, or 'Layout' = Static (or Dynamic with 'Initial layout' = "
                   "Static)");
  if (d.layout == "Dynamic" && !(d.eps_lower < d.eps_threshold))
    params::fail(pl, "Lower threshold", params::str(d.eps_lower),
                 "must be below 'Shallowness threshold' = " + params::str(d.eps_threshold) +
                     " (the hysteresis between the two keeps interfaces from flickering); "
                     "allowed: 0 <= Lower threshold < " + params::str(d.eps_threshold));
  if (dynamic && d.hold_time < d.check_interval) {
    // the parameter the scene changed is the one named: a raised 'Check interval' against the
    // default 'Hold time' was reported as a wrong Hold time (an independent run)
    if (user && user->isParameter("Check interval") && !user->isParameter("Hold time"))
      params::fail(pl, "Check interval", params::str(d.check_interval),
                   "must not exceed 'Hold time' = " + params::str(d.hold_time) +
                       " s (its default; a column goes back to 1D only once it was calm at two "
                       "checks); allowed: Check interval <= " + params::str(d.hold_time) +
                       " s, or a 'Hold time' of at least the Check interval");
    params::fail(pl, "Hold time", params::str(d.hold_time),
                 "must be at least 'Check interval' = " + params::str(d.check_interval) +
                     " s (a column goes back to 1D only once it was calm at two checks; a "
                     "shorter hold lets an interface flip at every check); allowed: Hold time >= " +
                     params::str(d.check_interval) + " s");
  }
  if (d.layout != "Static" && d.min_length > channel.length)
    params::fail(pl, "Minimum length", params::str(d.min_length),
                 "must not exceed the channel length L = " + params::str(channel.length) +
                     " m (no subdomain could be built); allowed: Minimum length <= " +
                     params::str(channel.length) + " m");
  if (d.layout == "Static" || (d.layout == "Dynamic" && d.initial_layout == "Static")) {
    if (d.models.size() != d.interfaces.size() + 1)
      params::fail(pl, "Models", Teuchos::toString(models),
                   "needs exactly one entry more than 'Interfaces' = " + params::str(d.interfaces) +
                       " (one model per subdomain)");
    double prev = 0.0;
    for (double x : d.interfaces) {
      if (!(x >= prev) || !(x <= channel.length))
        params::fail(pl, "Interfaces", params::str(d.interfaces),
                     "positions must not decrease and must lie in [0, L = " +
                         params::str(channel.length) +
                         "] (equal neighbours give a subdomain of zero length, which is left "
                         "out); allowed: 0 <= x_1 <= x_2 <= ... <= " +
                         params::str(channel.length) + " m");
      prev = x;
    }
    if (channel.left.type == core::BoundaryType::Periodic && d.normalised(channel.length).models.size() > 1)
      params::fail(pl, "Models", Teuchos::toString(models),
                   "a periodic channel cannot be split into subdomains; allowed: one subdomain");
  }
  return d;
}

Decomposition Decomposition::normalised(double length) const {
  // A subdomain of zero length holds no cell of either model, so it is left out; its two
  // neighbours then touch, and when they run the same model there is no interface between them
  // that either model's conditions would describe: they become one subdomain. (This is also
  // what a domain manager does when a 1D region between two 2D ones shrinks to nothing.)
  Decomposition d = *this;
  if (models.size() != interfaces.size() + 1) return d;  // a priori: replaced before building
  d.models.clear();
  d.interfaces.clear();
  // An interface the user asked for between two subdomains of the same model (1D | 1D) stays.
  bool dropped = false;  // a zero-length subdomain since the last one kept
  for (std::size_t i = 0; i < models.size(); ++i) {
    const auto [a, b] = extent(i, length);
    if (!(b > a)) {  // zero length (an end piece at x = 0 or x = L included)
      dropped = true;
      continue;
    }
    const bool merge = dropped && !d.models.empty() && d.models.back() == models[i];
    dropped = false;
    if (merge) continue;  // the previous subdomain extends to b
    if (!d.models.empty()) d.interfaces.push_back(a);
    d.models.push_back(models[i]);
  }
  if (d.models.empty()) d.models.push_back(models.back());
  return d;
}

std::array<double, 2> Decomposition::extent(std::size_t i, double length) const {
  const double a = i == 0 ? 0.0 : interfaces[i - 1];
  const double b = i == interfaces.size() ? length : interfaces[i];
  return {a, b};
}

// ---------------------------------------------------------------------------------------------
// CoupledModel
// ---------------------------------------------------------------------------------------------
CoupledModel::CoupledModel(std::vector<Subdomain> parts, const InterfaceOptions& options,
                           std::shared_ptr<const SubdomainFactory> factory)
    : parts_(std::move(parts)), options_(options), factory_(std::move(factory)) {
  if (parts_.empty()) throw std::invalid_argument("CoupledModel: no subdomains");
  for (const auto& p : parts_) initial_mass_ += p.model->mass_balance().initial;
  reconnect();
}

CoupledModel::~CoupledModel() = default;

void CoupledModel::reconnect() {
  interfaces_.clear();
  for (std::size_t i = 0; i + 1 < parts_.size(); ++i) {
    interfaces_.push_back(std::make_unique<Interface>(parts_[i], parts_[i + 1], options_));
    interfaces_.back()->connect();
  }
  // Step order: along the channel, except that the upstream side of an interface whose
  // downstream side reads its tentative step goes first (interface.hpp). Such constraints
  // only point downstream, so a part is stepped once everything it waits for has been.
  step_order_.clear();
  std::vector<char> done(parts_.size(), 0);
  while (step_order_.size() < parts_.size())
    for (std::size_t i = 0; i < parts_.size(); ++i) {
      if (done[i]) continue;
      if (i > 0 && interfaces_[i - 1]->upstream_steps_first() && !done[i - 1]) continue;
      done[i] = 1;
      step_order_.push_back(i);
    }
}

void CoupledModel::replace_parts(std::size_t first, std::size_t count,
                                 std::vector<Subdomain> with) {
  if (count == 0 || first + count > parts_.size() || with.empty())
    throw std::invalid_argument("CoupledModel::replace_parts: no parts to replace");
  const double a = parts_[first].x0, b = parts_[first + count - 1].x1;
  if (with.front().x0 != a || with.back().x1 != b)
    throw std::invalid_argument("CoupledModel::replace_parts: the new parts must cover [" +
                                params::str(a) + ", " + params::str(b) + "]");
  // The run's inflow and outflow booked by a replaced end part stay booked; what its
  // successor reports is added on top.
  if (first == 0)
    retired_inflow_ += parts_.front().model->mass_balance().inflow -
                       with.front().model->mass_balance().inflow;
  if (first + count == parts_.size())
    retired_outflow_ += parts_.back().model->mass_balance().outflow -
                        with.back().model->mass_balance().outflow;
  interfaces_.clear();  // they point into the parts
  parts_.erase(parts_.begin() + static_cast<std::ptrdiff_t>(first),
               parts_.begin() + static_cast<std::ptrdiff_t>(first + count));
  parts_.insert(parts_.begin() + static_cast<std::ptrdiff_t>(first),
                std::make_move_iterator(with.begin()), std::make_move_iterator(with.end()));
  reconnect();
}

Decomposition CoupledModel::layout() const {
  Decomposition d;
  d.models.clear();  // the defaults are the paper's layout
  d.interfaces.clear();
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    d.models.push_back(parts_[i].kind);
    if (i > 0) d.interfaces.push_back(parts_[i].x0);
  }
  return d;
}

void CoupledModel::set_domain_manager(std::unique_ptr<DomainManager> m) { manager_ = std::move(m); }

bool CoupledModel::adapt() { return manager_ && manager_->adapt(*this); }

// The common step. With sub-cycling it is the 2D parts' (their CFL condition with the flow
// speed), and each DAM takes steps of its own inside it (its CFL condition holds the gravity-wave
// speed sqrt(beta h) as well, which made the coupled run take 18-40 % more steps than full 2D),
// up to kMaxSubsteps of them; without 2D parts, or without sub-cycling, it is every part's.
double CoupledModel::stable_dt() const {
  double dt2 = std::numeric_limits<double>::infinity(), dt1 = dt2;
  part_dt_.assign(parts_.size(), 0.0);
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    const auto& p = parts_[i];
    part_dt_[i] = p.model->stable_dt();
    (p.one_d() ? dt1 : dt2) = std::min(p.one_d() ? dt1 : dt2, part_dt_[i]);
  }
  const bool sub = subcycling_ && std::isfinite(dt2);
  if (sub)
    for (std::size_t i = 0; i < parts_.size(); ++i)
      if (parts_[i].one_d()) part_dt_[i] *= kMaxSubsteps;
  return sub ? std::min(dt2, kMaxSubsteps * dt1) : std::min(dt1, dt2);
}

// The part whose stable step the common step dt is, by its place in the channel, and what set
// that part's step; or the driver's cut (an output time, the end, 'Max time step').
std::string CoupledModel::dt_setter(double dt) const {
  if (part_dt_.size() != parts_.size()) return "unknown";
  std::size_t best = 0;
  for (std::size_t i = 1; i < parts_.size(); ++i)
    if (part_dt_[i] < part_dt_[best]) best = i;
  if (dt < part_dt_[best] * (1.0 - 1e-9)) return "the driver (output time, end time, Max time step)";
  const auto& p = parts_[best];
  const bool first = best == 0, last = best + 1 == parts_.size();
  std::string where = p.kind + (first && last ? " (the whole channel)"
                                : first       ? " part at the upstream end"
                                : last        ? " part at the downstream end"
                                              : " part inside");
  if (p.ndam) return where + ": " + p.ndam->dt_cause();
  return where + ": wave speed |u| + sqrt(beta h)";
}

void CoupledModel::step(double dt) {
  ++dt_set_by_[dt_setter(dt)];
  last_dt_ = dt;
  // Every subdomain steps from the states at t, in the order of the interface contract.
  for (std::size_t i : step_order_) parts_[i].model->step(dt);
}

core::Health CoupledModel::check() const {
  for (const auto& p : parts_) {
    auto h = p.model->check();
    if (!h.ok) {
      h.reason += " (in the " + p.kind + " subdomain [" + params::str(p.x0) + ", " +
                  params::str(p.x1) + "] m)";
      return h;
    }
  }
  return {};
}

void CoupledModel::accept() {
  for (auto& p : parts_) p.model->accept();
  for (auto& f : interfaces_) {
    f->book();
    f->settle(last_dt_, relaxation_);
  }
  ++steps_;
}

void CoupledModel::settle_interfaces() {
  for (auto& f : interfaces_) {
    f->settle(0.0, 0.0);
    if (f->downstream().one_d()) {  // what the DAM could not take
      const double rest = f->carried();
      if (rest != 0.0) settle_leftovers_.push_back({f->x(), rest});
      f->restore({f->mass()[1], f->mass()[1]});
    }
  }
}

// A leftover is mass the DAM took through its ghosts ahead of the 2D side's markers (negative:
// the 2D columns still hold it) or the reverse, below one marker. Measured (a dynamic Setup II
// at 10 mm with a 1e-4 s check interval, the front reaching x_IF = 0.2 m as the 2D part shrank
// to 0.11 m): the nearly dry DAM could give back only half of the 1.38e-5 m^2 it had taken, and
// booking the rest as unplaced left the fields 6.9e-6 m^2 above the true mass. After the move
// the DAM covering x_IF holds the converted columns, and with them that mass.
// Where the 2D part grew over x_IF instead, the converted columns hold it as markers and no DAM
// covers x_IF: the leftover is carried on at the interface where the grown part now ends, and
// the DAM beyond it settles it there (booked as unplaced before: a gate part growing with a
// front, one column per move, left the fields 1.49e-6 m^2 above the true mass in five moves,
// a quarter of a marker, with a ledger that closed to 1e-19; an independent run).
void CoupledModel::place_settle_leftovers() {
  auto same = [](double a, double b) { return std::abs(a - b) <= 1e-12 * (1.0 + std::abs(b)); };
  auto downstream_1d_at = [&](double x) -> Interface* {
    for (auto& f : interfaces_)
      if (f->downstream().one_d() && same(f->x(), x)) return f.get();
    return nullptr;
  };
  for (const auto& [x, m] : settle_leftovers_) {
    double rest = m;
    Interface* f = downstream_1d_at(x);  // the interface is still at x
    for (std::size_t i = 0; i < parts_.size() && !f; ++i)  // a 2D part that grew over x
      if (!parts_[i].dam && x > parts_[i].x0 && x < parts_[i].x1)
        f = downstream_1d_at(parts_[i].x1);
    if (f) {
      const auto mm = f->mass();
      f->restore({mm[0] + rest, mm[1]});  // carried on, settled by the DAM beyond
      rest = 0.0;
    }
    for (std::size_t i = 0; i < parts_.size() && rest != 0.0; ++i) {
      auto& p = parts_[i];
      if (!p.dam || x < p.x0 || x > p.x1) continue;
      const double placed = p.dam->take_interface_mass(rest, 0.0);
      // take_interface_mass books what it places as the DAM's inflow; for the first part that
      // is the run's inflow, which this mass is not
      if (i == 0) retired_inflow_ -= placed;
      rest -= placed;
    }
    unplaced_ += rest;
  }
  settle_leftovers_.clear();
}

std::vector<core::LayoutPiece> CoupledModel::layout_pieces() const {
  std::vector<core::LayoutPiece> out;
  for (const auto& p : parts_) out.push_back({p.kind, p.x0, p.x1});
  return out;
}

core::Profile CoupledModel::profile() const {
  core::Profile out;
  for (const auto& p : parts_) {
    const auto q = p.model->profile();
    for (std::size_t k = 0; k < q.x.size(); ++k)
      out.append(q.x[k], q.h[k], q.u_mean[k], q.eps[k], q.model[k]);
  }
  return out;
}

core::MassBalance CoupledModel::mass_balance() const {
  // Totals over the subdomains; what crosses an interior interface leaves one subdomain and
  // enters the next, so any mismatch of the two sides shows up in the defect.
  core::MassBalance m;
  m.initial = initial_mass_;
  for (const auto& p : parts_) m.current += p.model->mass_balance().current;
  // mass between the two sides of an interface: carried into a DAM (Interface::settle), held by
  // a 2D inflow behind a 1D -> 2D interface (its gate's fractional markers and carried mass)
  for (const auto& f : interfaces_) m.current += f->carried();
  m.current += unplaced_;
  m.inflow = retired_inflow_ + parts_.front().model->mass_balance().inflow;
  m.outflow = retired_outflow_ + parts_.back().model->mass_balance().outflow;
  m.pending_inflow = parts_.front().model->mass_balance().pending_inflow;  // a 2D gate's
  return m;
}

// The subdomain with the smallest stable step says what sets it (every part asked: collective).
std::string CoupledModel::dt_limit() const {
  double best = std::numeric_limits<double>::infinity();
  std::string what;
  for (const auto& p : parts_) {
    const double dt = p.model->stable_dt();
    const std::string lim = p.model->dt_limit();
    if (dt < best) {
      best = dt;
      what = lim + " (in the " + p.kind + " subdomain [" + params::str(p.x0) + ", " +
             params::str(p.x1) + "] m)";
    }
  }
  return what;
}

core::Speed CoupledModel::max_speed() const {
  core::Speed s;
  for (const auto& p : parts_) {
    const core::Speed q = p.model->max_speed();  // collective in a 2D part: every part, always
    if (q.value > s.value || s.quantity.empty()) s = q;
  }
  return s;
}

// One channel-wide mesh per kind, whatever the layout, so that a field series stays one
// series in ParaView while the interfaces move: "dam", the depth-averaged state h, u_mean, hu
// and the model (1 or 2) of every DAM-sized cell of [0, L] (from the 1D cells and the 2D
// columns alike), a strip under the bed (z in [-0.01, 0]); "ndam", the 2D fields on the
// channel-wide 2D grid, with flag -1 (and zero fields) in the columns that are 1D at this
// output.
void CoupledModel::write_fields(io::FieldWriter& w) const {
  const double L = parts_.back().x1;
  const ChannelField f = channel_field(parts_, 0, parts_.size());
  const double dx1 = factory_ ? factory_->dx_1d() : parts_.front().x1 - parts_.front().x0;
  const int n1 = static_cast<int>(std::lround(L / dx1));
  std::vector<double> xn(static_cast<std::size_t>(n1 + 1)), h, u, hu, model;
  for (int j = 0; j <= n1; ++j) xn[static_cast<std::size_t>(j)] = j == n1 ? L : j * dx1;
  // In a 1D part the cells are the DAM's own on the primary grid, the values those of its
  // profile (DamSolver::primary, as profiles.csv; the staggered grid's cells would be half a
  // cell off every other step); in a 2D part the columns' averages (h of the markers, eq. 21).
  std::vector<core::Profile> prof(parts_.size());
  for (std::size_t p = 0; p < parts_.size(); ++p)
    if (parts_[p].one_d()) prof[p] = parts_[p].model->profile();
  for (int j = 0; j < n1; ++j) {
    const double a = xn[static_cast<std::size_t>(j)], b = xn[static_cast<std::size_t>(j + 1)];
    const double xc = 0.5 * (a + b);
    std::size_t p = 0;
    while (p + 1 < parts_.size() && xc > parts_[p].x1) ++p;
    model.push_back(parts_[p].one_d() ? 1.0 : 2.0);
    const auto& q = prof[p];
    if (parts_[p].one_d() && !q.x.empty()) {
      const double dxp = (parts_[p].x1 - parts_[p].x0) / static_cast<double>(q.x.size());
      const auto i = static_cast<std::size_t>(std::clamp(
          static_cast<int>(std::floor((xc - parts_[p].x0) / dxp)), 0,
          static_cast<int>(q.x.size()) - 1));
      h.push_back(q.h[i]);
      u.push_back(q.u_mean[i]);
      hu.push_back(q.h[i] * q.u_mean[i]);
      continue;
    }
    const auto v = f.average(a, b);
    h.push_back(v[0]);
    hu.push_back(v[1]);
    u.push_back(v[0] > 0.0 ? v[1] / v[0] : 0.0);
  }
  // drawn as a strip 1 cm deep under the bed, so that ParaView shows it beside the 2D box
  auto& m1 = w.add_mesh("dam", std::move(xn), {-0.01, 0.0});
  m1.cell_fields.emplace_back("h", h);
  m1.cell_fields.emplace_back("u", u);
  m1.cell_fields.emplace_back("hu", hu);
  m1.cell_fields.emplace_back("model", model);
  if (!factory_ || !factory_->has_2d()) return;
  const auto& g = factory_->two_d().cfg.grid;
  const double dx2 = factory_->dx_2d();
  const int nx = static_cast<int>(std::lround(L / dx2)), nz = g.nz;
  std::vector<double> x2(static_cast<std::size_t>(nx + 1)), z2(static_cast<std::size_t>(nz + 1));
  for (int i = 0; i <= nx; ++i) x2[static_cast<std::size_t>(i)] = i == nx ? L : i * dx2;
  for (int k = 0; k <= nz; ++k) z2[static_cast<std::size_t>(k)] = k * g.dz();
  std::vector<std::pair<std::string, std::vector<double>>> fields;
  for (const auto& p : parts_) {
    if (!p.ndam) continue;
    io::FieldWriter part;
    p.model->write_fields(part);
    const auto& mesh = part.meshes().front();
    const int nxp = static_cast<int>(mesh.x_nodes.size()) - 1;
    const int off = static_cast<int>(std::lround(p.x0 / dx2));
    for (const auto& [name, values] : mesh.cell_fields) {
      auto it = std::find_if(fields.begin(), fields.end(),
                             [&](const auto& q) { return q.first == name; });
      if (it == fields.end()) {
        fields.emplace_back(name, std::vector<double>(static_cast<std::size_t>(nx * nz),
                                                      name == "flag" ? -1.0 : 0.0));
        it = fields.end() - 1;
      }
      for (int k = 0; k < nz; ++k)
        for (int i = 0; i < nxp && off + i < nx; ++i)
          it->second[static_cast<std::size_t>(k * nx + off + i)] =
              values[static_cast<std::size_t>(k * nxp + i)];
    }
  }
  if (fields.empty()) {  // no 2D part at this output: the same fields, all 1D columns
    for (const char* name : {"u", "w", "p", "p_Pa", "nu_eff", "div_u", "flag"})
      fields.emplace_back(name, std::vector<double>(static_cast<std::size_t>(nx * nz),
                                                    std::string(name) == "flag" ? -1.0 : 0.0));
  }
  auto& m2 = w.add_mesh("ndam", std::move(x2), std::move(z2));
  m2.cell_fields = std::move(fields);
}

void CoupledModel::save(io::Checkpoint& c) const {
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    io::Checkpoint part;
    parts_[i].model->save(part);
    const std::string pre = "part" + std::to_string(i) + "/";
    for (const auto& [k, v] : part.scalars()) c.set(pre + k, v);
    for (const auto& [k, v] : part.arrays()) c.set(pre + k, v);
  }
  c.set("coupled/steps", static_cast<double>(steps_));
  // the decomposition: model of each part (1 or 2) and the interface positions
  std::vector<double> kinds, xs;
  for (const auto& p : parts_) kinds.push_back(p.one_d() ? 1.0 : 2.0);
  for (std::size_t i = 1; i < parts_.size(); ++i) xs.push_back(parts_[i].x0);
  c.set("coupled/models", kinds);
  c.set("coupled/interfaces", xs);
  c.set("coupled/ledger",
        std::vector<double>{initial_mass_, retired_inflow_, retired_outflow_, unplaced_});
  if (manager_) manager_->save(c);
  for (std::size_t i = 0; i < interfaces_.size(); ++i) {
    const auto m = interfaces_[i]->mass();
    c.set("coupled/interface" + std::to_string(i), std::vector<double>{m[0], m[1]});
  }
}

void CoupledModel::restart_point() {
  for (auto& p : parts_) p.model->restart_point();
}

void CoupledModel::load(const io::Checkpoint& c) {
  // The layout of the checkpoint must be this model's (a changed scene is refused).
  if (c.arrays().count("coupled/models")) {
    const auto& kinds = c.array("coupled/models");
    const auto& xs = c.array("coupled/interfaces");
    bool same = kinds.size() == parts_.size() && xs.size() + 1 == parts_.size();
    for (std::size_t i = 0; same && i < parts_.size(); ++i) {
      same = (kinds[i] == 1.0) == parts_[i].one_d();
      if (same && i > 0) same = std::abs(xs[i - 1] - parts_[i].x0) <= 1e-12;
    }
    if (!same && manager_ && factory_) {
      // A dynamic run: the parts of the checkpoint's layout, then their states below.
      std::vector<Subdomain> rebuilt;
      const double L = factory_->length();
      for (std::size_t i = 0; i < kinds.size(); ++i) {
        const double x0 = i == 0 ? 0.0 : xs[i - 1], x1 = i + 1 == kinds.size() ? L : xs[i];
        rebuilt.push_back(factory_->initial(kinds[i] == 1.0 ? "1D" : "2D", x0, x1,
                                            Neighbours{i > 0, i + 1 < kinds.size()}));
      }
      replace_parts(0, parts_.size(), std::move(rebuilt));
      same = true;
    }
    if (!same) {
      std::string saved, here;
      for (std::size_t i = 0; i < kinds.size(); ++i)
        saved += (i ? " | " : "") + std::string(kinds[i] == 1.0 ? "1D" : "2D") +
                 (i + 1 < kinds.size() ? " " + params::str(xs[i]) : "");
      for (std::size_t i = 0; i < parts_.size(); ++i)
        here += (i ? " | " : "") + parts_[i].kind +
                (i + 1 < parts_.size() ? " " + params::str(parts_[i].x1) : "");
      throw params::InputError("checkpoint layout (" + saved +
                               ") differs from the scene's (" + here + ")");
    }
  }
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    io::Checkpoint part;
    const std::string pre = "part" + std::to_string(i) + "/";
    for (const auto& [k, v] : c.scalars())
      if (k.rfind(pre, 0) == 0) part.set(k.substr(pre.size()), v);
    for (const auto& [k, v] : c.arrays())
      if (k.rfind(pre, 0) == 0) part.set(k.substr(pre.size()), v);
    parts_[i].model->load(part);
  }
  steps_ = static_cast<long>(c.scalar("coupled/steps"));
  if (c.arrays().count("coupled/ledger")) {
    const auto& l = c.array("coupled/ledger");
    initial_mass_ = l.at(0);
    retired_inflow_ = l.at(1);
    retired_outflow_ = l.at(2);
    unplaced_ = l.size() > 3 ? l.at(3) : 0.0;
  } else {
    initial_mass_ = 0.0;
    for (const auto& p : parts_) initial_mass_ += p.model->mass_balance().initial;
  }
  if (manager_) manager_->load(c);
  // the interfaces stay connected (reconnecting would reset the 2D inflow's state)
  for (std::size_t i = 0; i < interfaces_.size(); ++i) {
    const auto& v = c.array("coupled/interface" + std::to_string(i));
    interfaces_[i]->restore({v.at(0), v.at(1)});
  }
}

bool CoupledModel::end_wall() const {
  const auto& last = parts_.back();
  if (last.ndam) return last.ndam->end_wall();
  // A 1D part at the wall: the DAM does not resolve the wall's pressure field (wall_load), so
  // there is a wall series only when a domain manager may make that part 2D later; a static
  // layout would write an empty wall.csv and a summary of zeros (an independent tester).
  return manager_ && factory_ && factory_->channel().right.type == core::BoundaryType::Wall;
}

std::optional<core::WallLoad> CoupledModel::wall_load() const {
  // The part at the wall is looked up at every call: the domain manager replaces parts, and the
  // run driver keeps the series (wall.csv) across such rebuilds.
  const auto& last = parts_.back();
  if (!last.ndam) return std::nullopt;  // a DAM does not resolve the wall's pressure field
  return last.ndam->wall_load();
}

void CoupledModel::report(nlohmann::json& s) const {
  nlohmann::json parts = nlohmann::json::array(), ifaces = nlohmann::json::array();
  for (const auto& p : parts_) {
    nlohmann::json q = nlohmann::json::object();
    p.model->report(q);
    const auto mb = p.model->mass_balance();
    parts.push_back({{"model", p.kind}, {"x0", p.x0}, {"x1", p.x1}, {"statistics", q},
                     {"mass", mb.current}, {"mass_defect", mb.defect()}});
  }
  for (const auto& f : interfaces_) {
    const auto m = f->mass();
    ifaces.push_back({{"x", f->x()},
                      {"upstream", f->upstream().kind},
                      {"downstream", f->downstream().kind},
                      {"mass_out_of_upstream", m[0]},
                      {"mass_into_downstream", m[1]},
                      {"mismatch", m[1] - m[0]},
                      {"carried", f->carried()}});
  }
  s["coupled"] = {{"subdomains", parts}, {"interfaces", ifaces}, {"steps", steps_},
                  {"mass_unplaced", unplaced_}};
  // steps per cause since this run started (or restarted); a step that was retried counts
  // once per try
  s["coupled"]["dt_set_by"] = dt_set_by_;
  if (manager_) manager_->report(s["coupled"]);
}

}  // namespace granflow::coupling
