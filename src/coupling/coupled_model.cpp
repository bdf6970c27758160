#include "granflow/coupling/coupled_model.hpp"

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
    auto pl = Teuchos::rcp(new Teuchos::ParameterList("Decomposition"));
    const Decomposition d;
    add_enum(*pl, "Layout", d.layout,
             "Static: the subdomains of 'Models' split at 'Interfaces'; A priori: a DAM run of "
             "the whole scene first computes eps = 1/Fr^2 and the model is 2D wherever "
             "eps >= 'Shallowness threshold' (plus 'Margin'), 1D elsewhere (paper section 4.1)",
             {"Static", "A priori"});
    auto kinds = Teuchos::rcp(new Teuchos::StringValidator(Teuchos::tuple<std::string>("1D", "2D")));
    pl->set("Models", Teuchos::Array<std::string>(d.models.begin(), d.models.end()),
            "model of each subdomain from upstream to downstream: 1D (DAM) or 2D (N-DAM); one "
            "more entry than 'Interfaces' (Static layout)",
            Teuchos::rcp(new Teuchos::ArrayStringValidator(kinds)));
    auto pos = Teuchos::rcp(new Teuchos::EnhancedNumberValidator<double>(0.0, 1e6));
    pl->set("Interfaces", Teuchos::Array<double>(d.interfaces.begin(), d.interfaces.end()),
            "[m] interface positions, non-decreasing in [0, L] (Static layout); the paper's "
            "Setup I/II layout is {0.2, 0.7}. A subdomain of zero length (equal neighbouring "
            "positions, or a position at 0 or L) is left out and same-model neighbours that then "
            "touch become one subdomain: {2D, 1D, 2D} with {a, a} is the full 2D model",
            Teuchos::rcp(new Teuchos::ArrayNumberValidator<double>(pos)));
    add_double(*pl, "Shallowness threshold", d.eps_threshold,
               "A priori layout: 2D wherever eps = 1/Fr^2 reaches this at any output time of the "
               "DAM run (the paper's minimum requirement at an interface is eps < 0.1)",
               1e-6, 1e6);
    add_double(*pl, "Margin", d.margin,
               "[m] A priori layout: each 2D region is widened by this on both sides (the paper: "
               "'somewhat greater than suggested by the one-dimensional simulation')",
               0.0, 1e6);
    add_double(*pl, "Minimum length", d.min_length,
               "[m] A priori layout: shorter 1D gaps and end pieces become 2D", 0.0, 1e6);
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

namespace {
std::string list(const std::vector<double>& v) {
  std::string s;
  for (double x : v) s += (s.empty() ? "" : ", ") + params::str(x);
  return "{" + s + "}";
}
}  // namespace

Decomposition Decomposition::from_parameters(const Teuchos::ParameterList& pl,
                                             const core::Channel& channel) {
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
  if (d.layout == "Static") {
    if (d.models.size() != d.interfaces.size() + 1)
      params::fail(pl, "Models", Teuchos::toString(models),
                   "needs exactly one entry more than 'Interfaces' = " + list(d.interfaces) +
                       " (one model per subdomain)");
    double prev = 0.0;
    for (double x : d.interfaces) {
      if (!(x >= prev) || !(x <= channel.length))
        params::fail(pl, "Interfaces", list(d.interfaces),
                     "positions must not decrease and must lie in [0, L = " +
                         params::str(channel.length) +
                         "] (equal neighbours give a subdomain of zero length, which is left out)");
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

double CoupledModel::stable_dt() const {
  double dt = std::numeric_limits<double>::infinity();
  for (const auto& p : parts_) dt = std::min(dt, p.model->stable_dt());
  return dt;
}

void CoupledModel::step(double dt) {
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
  for (auto& f : interfaces_) f->book();
  ++steps_;
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
  m.inflow = retired_inflow_ + parts_.front().model->mass_balance().inflow;
  m.outflow = retired_outflow_ + parts_.back().model->mass_balance().outflow;
  return m;
}

void CoupledModel::write_fields(io::FieldWriter& w) const {
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    io::FieldWriter part;
    parts_[i].model->write_fields(part);
    for (const auto& m : part.meshes()) {
      auto& copy = w.add_mesh(m.name + "_" + std::to_string(i), m.x_nodes, m.z_nodes);
      copy.cell_fields = m.cell_fields;
    }
  }
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
  c.set("coupled/ledger", std::vector<double>{initial_mass_, retired_inflow_, retired_outflow_});
  for (std::size_t i = 0; i < interfaces_.size(); ++i) {
    const auto m = interfaces_[i]->mass();
    c.set("coupled/interface" + std::to_string(i), std::vector<double>{m[0], m[1]});
  }
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
  } else {
    initial_mass_ = 0.0;
    for (const auto& p : parts_) initial_mass_ += p.model->mass_balance().initial;
  }
  // the interfaces stay connected (reconnecting would reset the 2D inflow's state)
  for (std::size_t i = 0; i < interfaces_.size(); ++i) {
    const auto& v = c.array("coupled/interface" + std::to_string(i));
    interfaces_[i]->restore({v.at(0), v.at(1)});
  }
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
                      {"mismatch", m[1] - m[0]}});
  }
  s["coupled"] = {{"subdomains", parts}, {"interfaces", ifaces}, {"steps", steps_}};
}

}  // namespace granflow::coupling
