// Tpetra/Belos/MueLu/Ifpack2 behind solvers::LinearSystem. This is the only translation unit of
// the project that includes these headers (compile time on two cores: ~15 s, ~0.7 GB).
//
// Choices, and why:
// - Row map: contiguous blocks, one per rank, as the models number their unknowns slab by slab;
//   the column map is built by Tpetra from the assembled global column indices, so periodic and
//   slab-crossing couplings need no special treatment here.
// - Belos through Belos::SolverFactory (the Tpetra instantiations are precompiled in
//   libbelostpetra): "CG" for the symmetric positive (semi-)definite pressure and momentum
//   systems, "GMRES"/"BICGSTAB" selectable for experiments.
// - MueLu smoothed aggregation with a relaxation coarse solve. The default direct coarse solve
//   (Amesos2 KLU2) returns wrong solutions on more than one rank with Debian's Trilinos 13.2
//   (shared/TRILINOS-NOTES.md), so `coarse: type` defaults to RELAXATION and check() rejects a
//   direct coarse solver at np > 1.
// - Ifpack2 (RILUK, RELAXATION, ...) as the alternative one-level preconditioner.
// - A preconditioner switch (add_stiff_switch, set_stiffness): a system whose conditioning
//   changes by orders of magnitude during a run (the N-DAM momentum system between a flow and
//   a deposit at rest) uses a cheap one-level preconditioner while that suffices and AMG where
//   the one-level iteration count would grow with the stiffness. The model supplies the
//   stiffness from its state, so the choice is the same in a straight and a restarted run.
#include "granflow/solvers/linear_system.hpp"

#include "granflow/params/parameters.hpp"

#include <BelosLinearProblem.hpp>
#include <BelosSolverFactory_Tpetra.hpp>
#include <BelosTpetraAdapter.hpp>
#include <Ifpack2_Factory.hpp>
#include <MueLu_CreateTpetraPreconditioner.hpp>
#include <Teuchos_CommHelpers.hpp>
#include <Teuchos_DefaultMpiComm.hpp>
#include <Tpetra_Core.hpp>
#include <Tpetra_CrsMatrix.hpp>
#include <Tpetra_MultiVector.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <iterator>
#include <limits>
#include <map>
#include <stdexcept>

namespace granflow::solvers {

namespace {
// Our MueLu defaults; a user's "MueLu" sublist is merged over them (recursive validation of the
// pass-through list is disabled, so Teuchos would not fill them in for a partial user list).
Teuchos::ParameterList default_muelu() {
  Teuchos::ParameterList ml("MueLu");
  ml.set("verbosity", "none");
  ml.set("multigrid algorithm", "sa");
  ml.set("coarse: type", "RELAXATION",
         "not KLU2/Klu: Amesos2 KLU2 is wrong on more than one rank in Debian's Trilinos 13.2");
  Teuchos::ParameterList cp("coarse: params");
  cp.set("relaxation: type", "Symmetric Gauss-Seidel");
  cp.set("relaxation: sweeps", 4);
  ml.set("coarse: params", cp);
  ml.set("coarse: max size", 200);
  ml.set("smoother: type", "RELAXATION");
  Teuchos::ParameterList sp("smoother: params");
  sp.set("relaxation: type", "Symmetric Gauss-Seidel");
  sp.set("relaxation: sweeps", 1);
  ml.set("smoother: params", sp);
  return ml;
}
const std::vector<std::string> kPreconditioners = {"MueLu", "Ifpack2 RILUK", "Ifpack2 RELAXATION",
                                                   "None"};
Teuchos::ParameterList merged_muelu(const Teuchos::ParameterList& p) {
  auto ml = default_muelu();
  if (p.isSublist("MueLu")) ml.setParameters(p.sublist("MueLu"));
  return ml;
}
}  // namespace

using SC = double;
using LO = Tpetra::Map<>::local_ordinal_type;
using GO = Tpetra::Map<>::global_ordinal_type;
using Map = Tpetra::Map<>;
using Matrix = Tpetra::CrsMatrix<SC>;
using MV = Tpetra::MultiVector<SC>;
using OP = Tpetra::Operator<SC>;
using Clock = std::chrono::steady_clock;
using Teuchos::ParameterList;
using Teuchos::RCP;
using Teuchos::rcp;

struct Session::Impl {
  Tpetra::ScopeGuard guard;
  Impl(int* argc, char*** argv) : guard(argc, argv) {}
};
Session::Session(int* argc, char*** argv) : impl_(std::make_unique<Impl>(argc, argv)) {}
Session::~Session() = default;

struct LinearSystem::Impl {
  RCP<const Teuchos::Comm<int>> comm;
  RCP<const Map> map;
  GO first = 0;
  LO nlocal = 0;
  ParameterList params;
  // Assembly buffer: the triplets in the order they were added, in three flat arrays
  // (capacity kept between assemblies), and the same entries grouped by local row in their
  // order of addition (group_rows). A buffer per row (one vector each) cost a cache miss per
  // row, and so did every pass over all local rows: the N-DAM leaves the rows of fixed faces
  // and of cells without material empty (identity rows), at 1.3 mm about 178 000 rows of the
  // momentum box against 10 000 with entries. So the assembly, the record, the compression
  // and the solve's copies work on the rows that got entries and on the kept rows only; a row
  // without entries costs nothing but its copy x = b in solve().
  std::vector<LO> add_row;
  std::vector<GO> add_col;
  std::vector<SC> add_val;
  bool add_ascending = true;       // rows added in non-decreasing order (the models do)
  std::vector<LO> grp_rows;        // the rows that got entries, ascending
  std::vector<size_t> grp_start;   // CSR offsets of their grouped entries (grp_rows.size() + 1)
  std::vector<GO> grp_col;         // grouped columns, values and rows when the rows came
  std::vector<SC> grp_val;         // unordered (a stable sort by row: grp_perm)
  std::vector<LO> grp_row;
  std::vector<size_t> grp_perm;
  const GO* gcol = nullptr;        // the grouped entries (add_* themselves when ascending)
  const SC* gval = nullptr;
  void group_rows();
  std::vector<size_t> row_start;  // pattern of the current matrix (CSR offsets, columns)
  std::vector<GO> pattern;
  std::vector<size_t> value_slot;  // where each entry of the pattern sits in Tpetra's values
  // Emission record of the last full assembly (repeat_values), per row with entries (rec_rows;
  // rec_index: a local row's place in it, -1 for a row without entries): the columns in the
  // order they were added, the sorted order of those entries, the merged entry each one is
  // summed into (and whether it is the first of its sum), whether the row is a single diagonal
  // entry (2: no; 1: nonzero; 0: zero), the merged CSR offsets (pre_start), and per merged
  // entry its place in Tpetra's values (-1: a trivial row).
  bool rec_valid = false;
  std::string rec_type;
  std::vector<LO> rec_rows;
  std::vector<int> rec_index;  // nlocal entries; set for rec_rows, reset when they change
  std::vector<size_t> rec_start;
  std::vector<GO> rec_cols;
  std::vector<std::uint32_t> rec_order;
  std::vector<size_t> rec_merged;
  std::vector<char> rec_first, rec_single;
  std::vector<size_t> pre_start;
  std::vector<long long> pre_dest;
  std::vector<SC> pre_values;  // the repeat path's merged values (capacity kept)
  std::vector<SC> cur_pre;     // the merged values of the current matrix (pre_start layout)
  bool updating = false;       // begin_update() ... end_update()
  bool repeat_values(const std::string& type, std::vector<SC>& pre) const;
  void merge_row(size_t a, const SC* added, SC* merged) const;
  bool update_values(const std::string& type);
  void install_values(const std::vector<SC>& pre);
  std::string next_type() const;
  void update_staleness();
  double rebuild_preconditioner();  // a fresh one for A (counted); returns its setup seconds
  RCP<Matrix> A;
  RCP<OP> prec;
  bool prec_stale = true;
  int prec_age = 0;      // assemblies since the preconditioner was built
  int fresh_iters = -1;  // iterations of the first solve with a fresh preconditioner
  int last_iters = 0;
  bool last_converged = true;
  bool held = false;  // hold_preconditioner(): keep it over assemblies while it is effective
  // Trivial rows (no entries: identity rows of fixed faces and cells without material; or a
  // single nonzero diagonal entry, as Dirichlet rows) that no other row references are solved
  // as x = b / d and left out of the Krylov system, which then holds only the coupled rows (in
  // the N-DAM chute: the cells with material). rmap numbers the kept rows contiguously, rank by
  // rank. A row without entries that the system must keep (referenced, or in a MueLu block with
  // a kept row) enters it as an identity row.
  MPI_Comm raw_comm = MPI_COMM_NULL;
  std::vector<GO> rank_first;       // first global row of each rank, and the total at the end
  std::vector<LO> kept;             // local rows in the Krylov system, ascending
  std::vector<int> kept_rec;        // per kept row: its place in rec_rows, -1 (no entries)
  std::vector<GO> kept_id;          // nlocal entries: a kept row's index in rmap, else -1
  std::vector<size_t> one_slots;    // Tpetra value slots of the kept rows without entries
  std::vector<int> triv_rec;        // trivial rows with an entry (places in rec_rows) ...
  std::vector<SC> triv_d;           // ... and their diagonal d
  RCP<const Map> rmap;              // map of the kept rows
  GO rfirst = 0;                    // first global index of this rank's kept rows in rmap
  GO rglobal = 0;                   // kept rows on all ranks
  int block = 1;                    // rows kept in blocks of this many: block_eq under MueLu
  int block_eq = 1;                 // MueLu's "number of equations" (1 if it does not fit)
  // The preconditioner switch: the type for the current matrix, the type of `prec`, and the
  // stiffness the model set for the next assembly.
  std::string prec_type, built_type;
  double stiffness = 0.0;
  double relax_damping = 0.0;  // set_relaxation_damping (0: Ifpack2's default, 1)
  void compress_rows(const std::vector<GO>& cols, const std::vector<SC>& vals,
                     std::vector<size_t>& kstart, std::vector<GO>& kcols, std::vector<SC>& kvals);
  // Work buffers of compress_rows() and end() in the number of rows, kept between assemblies
  // (malloc, free and memset were 3-4 % of a 2.6 mm Setup II run). The buffers in the number
  // of entries are not kept: they would hold a second copy of the pattern for the whole run
  // (the 256 x 256 cavity of cli.memory_estimate: its peak rose from 351 to 363 MB).
  std::vector<LO> buf_old_kept, buf_forced, buf_keep, buf_coupled;
  std::vector<char> buf_triv;
  std::vector<std::vector<GO>> buf_ask;
  RCP<MueLu::HierarchyManager<SC, LO, GO, Map::node_type>> muelu;  // cached interpreter
  long long pattern_builds = 0;     // graphs built (the pattern changed)
  long long repeats = 0;            // assemblies that took the repeat path
  long long prec_setups = 0;        // preconditioners built
  double prec_setup_seconds = 0.0;  // their total setup time
  double krylov_seconds = 0.0;      // the Krylov solves' time (solve() less the setups)
  long long prec_retries = 0;        // solves repeated with a fresh one (a kept one failed)
};

LinearSystem::LinearSystem(MPI_Comm comm, long long global_rows, long long first_row,
                           int local_rows, const ParameterList& params)
    : impl_(std::make_unique<Impl>()) {
  auto& m = *impl_;
  m.comm = rcp(new Teuchos::MpiComm<int>(comm));
  m.first = first_row;
  m.nlocal = local_rows;
  m.params = params;
  m.params.set("MueLu", merged_muelu(params));
  // A contiguous map with a given local count; Tpetra checks that the counts sum to the global.
  m.map = rcp(new Map(static_cast<Tpetra::global_size_t>(global_rows),
                      static_cast<size_t>(local_rows), 0, m.comm));
  if (m.map->getMinGlobalIndex() != first_row && local_rows > 0)
    throw std::logic_error("LinearSystem: rows must be numbered in rank order");
  m.raw_comm = comm;
  if (m.params.sublist("MueLu").isParameter("number of equations")) {
    m.block_eq = m.params.sublist("MueLu").get<int>("number of equations");
    if (m.block_eq < 1 || local_rows % m.block_eq != 0 || first_row % m.block_eq != 0)
      m.block_eq = 1;
  }
  m.prec_type = m.params.get<std::string>("Preconditioner");
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  std::vector<long long> firsts(static_cast<size_t>(ranks));
  long long my_first = first_row;
  MPI_Allgather(&my_first, 1, MPI_LONG_LONG, firsts.data(), 1, MPI_LONG_LONG, comm);
  m.rank_first.assign(firsts.begin(), firsts.end());
  m.rank_first.push_back(global_rows);
  m.rec_index.assign(static_cast<size_t>(local_rows), -1);
  m.kept_id.assign(static_cast<size_t>(local_rows), -1);
  m.grp_start.assign(1, 0);
}

LinearSystem::~LinearSystem() = default;

long long LinearSystem::preconditioner_setups() const { return impl_->prec_setups; }
double LinearSystem::preconditioner_setup_seconds() const { return impl_->prec_setup_seconds; }
double LinearSystem::krylov_seconds() const { return impl_->krylov_seconds; }
long long LinearSystem::pattern_builds() const { return impl_->pattern_builds; }
long long LinearSystem::preconditioner_retries() const { return impl_->prec_retries; }
long long LinearSystem::repeat_assemblies() const { return impl_->repeats; }

long long LinearSystem::global_rows() const {
  return static_cast<long long>(impl_->map->getGlobalNumElements());
}
int LinearSystem::local_rows() const { return impl_->nlocal; }

void LinearSystem::begin() {
  impl_->add_row.clear();
  impl_->add_col.clear();
  impl_->add_val.clear();
  impl_->add_ascending = true;
}

void LinearSystem::begin_update() {
  begin();
  impl_->updating = true;
}

bool LinearSystem::end_update() {
  auto& m = *impl_;
  if (!m.updating) throw std::logic_error("LinearSystem::end_update without begin_update");
  m.updating = false;
  m.group_rows();
  const int ok_local = m.update_values(m.next_type()) ? 1 : 0;
  int ok = 0;
  Teuchos::reduceAll<int, int>(*m.comm, Teuchos::REDUCE_MIN, ok_local, Teuchos::outArg(ok));
  if (ok == 1) {
    m.install_values(m.cur_pre);
    return true;
  }
  // some rank refused: cur_pre may hold new rows (on any rank), and the caller now assembles
  // every row anew, so the record is dropped on every rank
  m.rec_valid = false;
  return false;
}

void LinearSystem::set_stiffness(double s) { impl_->stiffness = s; }
void LinearSystem::set_relaxation_damping(double omega) { impl_->relax_damping = omega; }

void LinearSystem::add(long long row, long long col, double v) {
  const long long lr = row - impl_->first;
  if (lr < 0 || lr >= impl_->nlocal) throw std::logic_error("LinearSystem::add: row not owned");
  auto& m = *impl_;
  if (m.add_row.size() == m.add_row.capacity()) {
    // grow by an eighth, not by doubling (as the record in end(): a steady run's emission count
    // wanders by a per cent, and a doubled buffer would be a step in its resident set)
    const size_t cap = m.add_row.size() + m.add_row.size() / 8 + 1024;
    m.add_row.reserve(cap);
    m.add_col.reserve(cap);
    m.add_val.reserve(cap);
  }
  if (!m.add_row.empty() && lr < m.add_row.back()) m.add_ascending = false;
  m.add_row.push_back(static_cast<LO>(lr));
  m.add_col.push_back(col);
  m.add_val.push_back(v);
}

namespace {
// Room for `need` elements; beyond the capacity it grows by an eighth, not by doubling (a
// steady run's emission count wanders by a per cent, and a doubled buffer would be a step in
// its resident set; cli.memory_steady_run).
template <class V>
void reserve_eighth(V& v, size_t need) {
  if (need > v.capacity()) v.reserve(need + need / 8);
}
}  // namespace

// Groups the added triplets by local row, keeping their order of addition within a row (the
// order of summation of duplicates): the rows that got entries and their CSR offsets, and,
// when the rows came in any order, a stable sort of the triplets by row into grp_col /
// grp_val. Work in the number of triplets, none per row without entries.
void LinearSystem::Impl::group_rows() {
  const size_t added = add_row.size();
  const LO* rows = add_row.data();  // the rows of the grouped entries, in their order
  if (add_ascending) {
    gcol = add_col.data();
    gval = add_val.data();
  } else {
    grp_perm.resize(added);
    for (size_t q = 0; q < added; ++q) grp_perm[q] = q;
    std::stable_sort(grp_perm.begin(), grp_perm.end(),
                     [&](size_t x, size_t y) { return add_row[x] < add_row[y]; });
    reserve_eighth(grp_col, added);
    reserve_eighth(grp_val, added);
    reserve_eighth(grp_row, added);
    grp_col.resize(added);
    grp_val.resize(added);
    grp_row.resize(added);
    for (size_t q = 0; q < added; ++q) {
      grp_col[q] = add_col[grp_perm[q]];
      grp_val[q] = add_val[grp_perm[q]];
      grp_row[q] = add_row[grp_perm[q]];
    }
    rows = grp_row.data();
    gcol = grp_col.data();
    gval = grp_val.data();
  }
  size_t distinct = 0;
  for (size_t q = 0; q < added; ++q)
    if (q == 0 || rows[q] != rows[q - 1]) ++distinct;
  reserve_eighth(grp_rows, distinct);
  reserve_eighth(grp_start, distinct + 1);
  grp_rows.clear();
  grp_start.clear();
  for (size_t q = 0; q < added; ++q)
    if (q == 0 || rows[q] != rows[q - 1]) {
      grp_rows.push_back(rows[q]);
      grp_start.push_back(q);
    }
  grp_start.push_back(added);
}

// Splits the assembled rows (merged CSR per row with entries, pre_start layout, in the original
// numbering) into trivial rows and the kept rows, and writes the kept rows with their columns
// renumbered for rmap (kstart, kcols, kvals; a kept row without entries as an identity row).
// A trivial row that another row references stays in the system (its coupling is not moved to
// the right-hand side); the models move such couplings to the right-hand side themselves, so
// this does not happen in the N-DAM and is only a safeguard. Under MueLu with b equations per
// node a block of b rows stays whole (the N-DAM momentum: the w face of a cell whose u face is
// an unknown). Collective. Work in the rows with entries and the kept rows.
void LinearSystem::Impl::compress_rows(const std::vector<GO>& cols, const std::vector<SC>& vals,
                                       std::vector<size_t>& kstart, std::vector<GO>& kcols,
                                       std::vector<SC>& kvals) {
  const size_t na = rec_rows.size();
  for (LO r : kept) kept_id[static_cast<size_t>(r)] = -1;  // the last assembly's
  std::vector<char>& triv = buf_triv;
  triv.assign(na, 0);
  for (size_t a = 0; a < na; ++a) {
    const size_t p = pre_start[a];
    triv[a] = pre_start[a + 1] - p == 1 && cols[p] == first + rec_rows[a] && vals[p] != 0.0;
  }
  // References to trivial rows (with an entry or without): local ones directly, remote ones by
  // asking their owners, who keep every row they are asked for.
  const int ranks = static_cast<int>(rank_first.size()) - 1;
  auto owner = [&](GO g) {
    return static_cast<int>(std::upper_bound(rank_first.begin(), rank_first.end() - 1, g) -
                            rank_first.begin()) - 1;
  };
  std::vector<LO>& forced = buf_forced;
  forced.clear();
  std::vector<std::vector<GO>>& ask = buf_ask;
  ask.resize(static_cast<size_t>(ranks));
  for (auto& a : ask) a.clear();
  for (size_t a = 0; a < na; ++a) {
    if (triv[a]) continue;
    for (size_t q = pre_start[a]; q < pre_start[a + 1]; ++q) {
      const GO c = cols[q];
      if (c >= first && c < first + nlocal) {
        const int ca = rec_index[static_cast<size_t>(c - first)];
        if (ca < 0 || triv[static_cast<size_t>(ca)]) forced.push_back(static_cast<LO>(c - first));
      } else {
        ask[static_cast<size_t>(owner(c))].push_back(c);
      }
    }
  }
  for (auto& a : ask) {
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
  }
  std::vector<GO> asked;  // the rows other ranks reference, by rank
  std::vector<int> scount(static_cast<size_t>(ranks)), rcount(scount.size()),
      sdispl(scount.size()), rdispl(scount.size());
  std::vector<GO> sendbuf;
  if (ranks > 1) {
    for (int r = 0; r < ranks; ++r) {
      scount[static_cast<size_t>(r)] = static_cast<int>(ask[static_cast<size_t>(r)].size());
      sdispl[static_cast<size_t>(r)] = static_cast<int>(sendbuf.size());
      sendbuf.insert(sendbuf.end(), ask[static_cast<size_t>(r)].begin(),
                     ask[static_cast<size_t>(r)].end());
    }
    MPI_Alltoall(scount.data(), 1, MPI_INT, rcount.data(), 1, MPI_INT, raw_comm);
    int tot = 0;
    for (int r = 0; r < ranks; ++r) {
      rdispl[static_cast<size_t>(r)] = tot;
      tot += rcount[static_cast<size_t>(r)];
    }
    asked.resize(static_cast<size_t>(tot));
    MPI_Alltoallv(sendbuf.data(), scount.data(), sdispl.data(), MPI_LONG_LONG, asked.data(),
                  rcount.data(), rdispl.data(), MPI_LONG_LONG, raw_comm);
    for (GO g : asked) forced.push_back(static_cast<LO>(g - first));
  }
  std::sort(forced.begin(), forced.end());
  forced.erase(std::unique(forced.begin(), forced.end()), forced.end());
  // the kept rows: the non-trivial ones and the forced ones
  std::vector<LO>& keep = buf_keep;
  keep.clear();
  keep.reserve(na + forced.size());
  {
    std::vector<LO>& coupled = buf_coupled;
    coupled.clear();
    coupled.reserve(na);
    for (size_t a = 0; a < na; ++a)
      if (!triv[a]) coupled.push_back(rec_rows[a]);
    std::set_union(coupled.begin(), coupled.end(), forced.begin(), forced.end(),
                   std::back_inserter(keep));
  }
  // MueLu's "number of equations" b > 1 needs whole blocks of b rows: a block stays when one
  // of its rows stays (blocks start at multiples of b: first_row and local_rows are)
  if (block > 1) {
    std::vector<LO> whole;
    whole.reserve(keep.size() + keep.size() / 2);
    for (LO r : keep) {
      const LO b0 = r - r % block;
      if (!whole.empty() && whole.back() >= b0) continue;  // this block is in already
      for (LO j = 0; j < block; ++j) whole.push_back(b0 + j);
    }
    keep.swap(whole);
  }
  // New numbering: the kept rows of rank 0, then those of rank 1, ...
  long long nk = static_cast<long long>(keep.size()), offset = 0, total = 0;
  MPI_Exscan(&nk, &offset, 1, MPI_LONG_LONG, MPI_SUM, raw_comm);
  MPI_Allreduce(&nk, &total, 1, MPI_LONG_LONG, MPI_SUM, raw_comm);
  int me = 0;
  MPI_Comm_rank(raw_comm, &me);
  if (me == 0) offset = 0;  // MPI_Exscan leaves rank 0's result undefined
  kept.swap(keep);
  for (size_t q = 0; q < kept.size(); ++q)
    kept_id[static_cast<size_t>(kept[q])] = offset + static_cast<GO>(q);
  // the trivial rows with an entry that stay out: x = b / d in solve()
  triv_rec.clear();
  triv_d.clear();
  for (size_t a = 0; a < na; ++a)
    if (triv[a] && kept_id[static_cast<size_t>(rec_rows[a])] < 0) {
      triv_rec.push_back(static_cast<int>(a));
      triv_d.push_back(vals[pre_start[a]]);
    }
  // Remote columns: the owners answer with the new numbers of the rows they were asked for.
  std::vector<GO> remote_old, remote_new;
  if (ranks > 1) {
    std::vector<GO> answer(asked.size());
    for (size_t q = 0; q < asked.size(); ++q)
      answer[q] = kept_id[static_cast<size_t>(asked[q] - first)];
    remote_new.resize(sendbuf.size());
    MPI_Alltoallv(answer.data(), rcount.data(), rdispl.data(), MPI_LONG_LONG, remote_new.data(),
                  scount.data(), sdispl.data(), MPI_LONG_LONG, raw_comm);
    remote_old = sendbuf;  // sorted within each rank's block, blocks in rank order: sorted
  }
  auto renumber = [&](GO c) -> GO {
    if (c >= first && c < first + nlocal) return kept_id[static_cast<size_t>(c - first)];
    const auto it = std::lower_bound(remote_old.begin(), remote_old.end(), c);
    return remote_new[static_cast<size_t>(it - remote_old.begin())];
  };
  // Kept rows only, columns renumbered (the numbering keeps the order, so rows stay sorted).
  kstart.assign(kept.size() + 1, 0);
  kcols.clear();
  kvals.clear();
  kcols.reserve(cols.size() + forced.size() + static_cast<size_t>(block) * forced.size());
  kvals.reserve(kcols.capacity());
  kept_rec.resize(kept.size());
  for (size_t q = 0; q < kept.size(); ++q) {
    const int a = rec_index[static_cast<size_t>(kept[q])];
    kept_rec[q] = a;
    if (a >= 0) {
      for (size_t p = pre_start[static_cast<size_t>(a)]; p < pre_start[static_cast<size_t>(a) + 1];
           ++p) {
        kcols.push_back(renumber(cols[p]));
        kvals.push_back(vals[p]);
      }
    } else {  // a kept row without entries: the identity row it stands for
      kcols.push_back(offset + static_cast<GO>(q));
      kvals.push_back(1.0);
    }
    kstart[q + 1] = kcols.size();
  }
  // A new map when the kept rows changed anywhere (Map construction is collective).
  int changed = rmap.is_null() || rfirst != offset || rglobal != total ||
                static_cast<long long>(rmap->getNodeNumElements()) != nk;
  int any_changed = 0;
  MPI_Allreduce(&changed, &any_changed, 1, MPI_INT, MPI_MAX, raw_comm);
  if (any_changed)
    rmap = rcp(new Map(static_cast<Tpetra::global_size_t>(total), static_cast<size_t>(nk), 0,
                       comm));
  rfirst = offset;
  rglobal = total;
}

// The emission record of the last full assembly (the rec_* members): when the next assembly adds
// the same (row, col) sequence, its values go straight to their places: no sorting, no
// compression, no pattern comparison. Returns false (and leaves everything unchanged) if the
// sequence or the preconditioner type differs, or if a single-diagonal row's value changed
// between zero and nonzero (that decides whether the row is trivial). Not collective.
bool LinearSystem::Impl::repeat_values(const std::string& type, std::vector<SC>& pre) const {
  if (!rec_valid || A.is_null() || type != rec_type) return false;
  if (grp_rows != rec_rows || grp_start != rec_start ||
      !std::equal(gcol, gcol + grp_start.back(), rec_cols.begin()))
    return false;
  reserve_eighth(pre, pre_start.back());
  pre.resize(pre_start.back());
  for (size_t a = 0; a < rec_rows.size(); ++a) {
    merge_row(a, gval + rec_start[a], pre.data() + pre_start[a]);
    if (rec_single[a] != 2 && (pre[pre_start[a]] != 0.0) != (rec_single[a] == 1)) return false;
  }
  return true;
}

// The merged entries of the record's row a (merged[0 ..]) from its values in the order they
// were added (added[0 ..]; the record's sequence), summed in the order of the full path: the
// sorted order, duplicates summed in it. Every merged entry is written (its first sum).
void LinearSystem::Impl::merge_row(size_t a, const SC* added, SC* merged) const {
  const size_t b = rec_start[a], size = rec_start[a + 1] - b, p0 = pre_start[a];
  for (size_t j = 0; j < size; ++j) {
    const size_t d = rec_merged[b + j] - p0;
    const double v = added[rec_order[b + j]];
    if (rec_first[b + j]) merged[d] = v;
    else merged[d] += v;
  }
}

// The preconditioner type of the matrix being assembled (the switch, if the list has one).
std::string LinearSystem::Impl::next_type() const {
  return params.isParameter("Stiff preconditioner") &&
                 stiffness >= params.get<double>("Stiff threshold")
             ? params.get<std::string>("Stiff preconditioner")
             : params.get<std::string>("Preconditioner");
}

// New values (pre_start layout) on the current graph: a new matrix, so that the old one stays
// intact for a lagged or held preconditioner that still refers to it.
void LinearSystem::Impl::install_values(const std::vector<SC>& pre) {
  for (size_t t = 0; t < triv_rec.size(); ++t)
    triv_d[t] = pre[pre_start[static_cast<size_t>(triv_rec[t])]];
  Matrix::local_matrix_device_type::values_type v("A values", value_slot.size());
  for (size_t q = 0; q < pre.size(); ++q)
    if (pre_dest[q] >= 0) v(static_cast<size_t>(pre_dest[q])) = pre[q];
  for (size_t s : one_slots) v(s) = 1.0;
  auto Anew = rcp(new Matrix(A->getCrsGraph(), v));
  Anew->fillComplete(rmap, rmap);
  A = Anew;
  ++repeats;
  update_staleness();
}

// The rows added since begin_update() replace theirs in cur_pre; each must add its sequence of
// the last full assembly (the record), and a single-diagonal row must stay zero or nonzero.
// Not collective. On false, cur_pre may hold some of the new rows: end_update() then drops the
// record on every rank, so the caller's full assembly rebuilds everything.
bool LinearSystem::Impl::update_values(const std::string& type) {
  if (!rec_valid || A.is_null() || type != rec_type || cur_pre.size() != pre_start.back())
    return false;
  for (size_t g = 0; g < grp_rows.size(); ++g) {
    const int a = rec_index[static_cast<size_t>(grp_rows[g])];
    if (a < 0) return false;  // a row without entries in the record
    const size_t s = grp_start[g], size = grp_start[g + 1] - s;
    const size_t b = rec_start[static_cast<size_t>(a)];
    if (size != rec_start[static_cast<size_t>(a) + 1] - b ||
        !std::equal(gcol + s, gcol + s + size, rec_cols.begin() + static_cast<std::ptrdiff_t>(b)))
      return false;
    SC* row = cur_pre.data() + pre_start[static_cast<size_t>(a)];
    merge_row(static_cast<size_t>(a), gval + s, row);
    const char single = rec_single[static_cast<size_t>(a)];
    if (single != 2 && (row[0] != 0.0) != (single == 1)) return false;
  }
  return true;
}

// Rows are sorted and duplicates summed. When the sparsity pattern is the one of the previous
// matrix (the usual case: only nu_eff or dt changed) the new matrix shares Tpetra's graph, and
// a lagged preconditioner may be reused. Measured (docs/validation.md, "Speed"): assembly was a
// quarter of Setup II's full 2D run at 1.3 mm; half of the assemblies (the momentum re-solves
// of the Coulomb friction) repeat the last one's sequence and take the repeat path.
void LinearSystem::end() {
  auto& m = *impl_;
  // The preconditioner of this matrix (the switch, if the list has one), and with it the
  // blocks of the Krylov system: MueLu's equations per node are kept whole, the one-level
  // preconditioners get exactly the coupled rows. The stiffness is the same on every rank.
  if (m.updating) throw std::logic_error("LinearSystem::end after begin_update");
  const std::string type = m.next_type();
  m.group_rows();
  {
    std::vector<SC>& pre = m.pre_values;
    const int repeat_local = m.repeat_values(type, pre) ? 1 : 0;
    int repeat_all = 0;
    Teuchos::reduceAll<int, int>(*m.comm, Teuchos::REDUCE_MIN, repeat_local,
                                 Teuchos::outArg(repeat_all));
    if (repeat_all == 1) {
      // the same pattern, kept rows and trivial rows: new values on the old graph
      m.install_values(pre);
      std::swap(m.cur_pre, pre);
      return;
    }
  }
  // the record is rewritten below; until the matrix is built it describes nothing (an
  // exception on the way must not leave a stale record for the next assembly's repeat path)
  m.rec_valid = false;
  for (LO r : m.rec_rows) m.rec_index[static_cast<size_t>(r)] = -1;
  const size_t na = m.grp_rows.size(), added = m.grp_start[na];
  // the merged rows (pre_start layout); their values are built in cur_pre itself (it was a
  // copy of them)
  std::vector<GO> cols;
  std::vector<SC>& vals = m.cur_pre;
  cols.reserve(added);
  vals.clear();
  vals.reserve(added);
  // the record of this emission sequence, for the repeat path of the next assembly
  reserve_eighth(m.rec_cols, added);
  reserve_eighth(m.rec_order, added);
  reserve_eighth(m.rec_merged, added);
  reserve_eighth(m.rec_first, added);
  reserve_eighth(m.rec_rows, na);
  reserve_eighth(m.rec_start, na + 1);
  reserve_eighth(m.rec_single, na);
  reserve_eighth(m.pre_start, na + 1);
  m.rec_rows = m.grp_rows;
  m.rec_start = m.grp_start;
  m.rec_cols.assign(m.gcol, m.gcol + added);
  m.rec_order.resize(added);
  m.rec_merged.resize(added);
  m.rec_first.resize(added);
  m.rec_single.assign(na, 2);
  m.pre_start.assign(na + 1, 0);
  std::vector<std::pair<GO, std::uint32_t>> order;
  for (size_t a = 0; a < na; ++a) {
    const LO i = m.rec_rows[a];
    m.rec_index[static_cast<size_t>(i)] = static_cast<int>(a);
    const size_t b = m.rec_start[a], size = m.rec_start[a + 1] - b;
    // sort (column, emission index) by column only: the same permutation std::sort gives the
    // (column, value) pairs, so the sums of duplicates keep their order
    order.resize(size);
    for (size_t j = 0; j < size; ++j) order[j] = {m.gcol[b + j], static_cast<std::uint32_t>(j)};
    if (size > 1)
      std::sort(order.begin(), order.end(),
                [](const auto& x, const auto& y) { return x.first < y.first; });
    for (size_t q = 0; q < size; ++q) {
      const double v = m.gval[b + order[q].second];
      const bool first = !(q > 0 && order[q].first == order[q - 1].first);
      if (first) {
        cols.push_back(order[q].first);
        vals.push_back(v);
      } else {
        vals.back() += v;
      }
      m.rec_order[b + q] = order[q].second;
      m.rec_merged[b + q] = cols.size() - 1;
      m.rec_first[b + q] = first ? 1 : 0;
    }
    m.pre_start[a + 1] = cols.size();
    if (m.pre_start[a + 1] - m.pre_start[a] == 1 && cols[m.pre_start[a]] == m.first + i)
      m.rec_single[a] = vals[m.pre_start[a]] != 0.0 ? 1 : 0;
  }
  std::vector<LO>& old_kept = m.buf_old_kept;
  old_kept.assign(m.kept.begin(), m.kept.end());
  const GO old_rfirst = m.rfirst;
  m.prec_type = type;
  m.block = m.prec_type == "MueLu" ? m.block_eq : 1;
  std::vector<size_t> start;
  std::vector<GO> kcols;
  std::vector<SC> kvals;
  m.compress_rows(cols, vals, start, kcols, kvals);
  // Collective decision: a pattern that changed on one rank only (e.g. the free-surface flags
  // of one slab) must rebuild the graph and the preconditioner on every rank; a rank-local
  // decision left one rank setting up MueLu while the other solved (deadlock, found with the
  // N-DAM chute at np = 2).
  const int same_local =
      !m.A.is_null() && m.kept == old_kept && m.rfirst == old_rfirst &&
              start == m.row_start && kcols == m.pattern
          ? 1
          : 0;
  int same_all = 0;
  Teuchos::reduceAll<int, int>(*m.comm, Teuchos::REDUCE_MIN, same_local, Teuchos::outArg(same_all));
  const bool same = same_all == 1;
  if (same) {
    // A new matrix on the old (static) graph: the old matrix stays intact for a lagged
    // preconditioner that still refers to it. The values go straight into Tpetra's local
    // storage order (value_slot, from the pattern build): no global-index lookups.
    // (every slot is written: value_slot is a permutation of the pattern's entries)
    Matrix::local_matrix_device_type::values_type v(
        Kokkos::ViewAllocateWithoutInitializing("A values"), m.value_slot.size());
    for (size_t q = 0; q < m.value_slot.size(); ++q) v(m.value_slot[q]) = kvals[q];
    auto A = rcp(new Matrix(m.A->getCrsGraph(), v));
    A->fillComplete(m.rmap, m.rmap);
    m.A = A;
  } else {
    // A new pattern, handed to Tpetra as local CSR arrays, so no sorting, merging or global
    // lookups happen inside Tpetra. The column map: this rank's kept rows in order, then the
    // remote columns by global index (which is by owning rank: rows are numbered rank by
    // rank). That is the map Tpetra's fillComplete builds whenever every kept row's own column
    // appears on its rank (a stored diagonal, as in the models' matrices); otherwise it holds
    // an owned index that no entry uses, which changes no product. Local columns sorted
    // within each row.
    const LO nk = static_cast<LO>(m.kept.size());
    const GO rfirst = m.rfirst;
    std::vector<GO> remote;
    for (GO c : kcols)
      if (c < rfirst || c >= rfirst + nk) remote.push_back(c);
    std::sort(remote.begin(), remote.end());
    remote.erase(std::unique(remote.begin(), remote.end()), remote.end());
    Teuchos::Array<GO> colgids(static_cast<size_t>(nk) + remote.size());
    for (LO i = 0; i < nk; ++i) colgids[static_cast<size_t>(i)] = rfirst + i;
    std::copy(remote.begin(), remote.end(), colgids.begin() + nk);
    auto colmap = rcp(new Map(Teuchos::OrdinalTraits<Tpetra::global_size_t>::invalid(),
                              colgids(), 0, m.comm));
    const size_t nnz = kcols.size();
    Matrix::local_graph_device_type::row_map_type::non_const_type ptr("A rows",
                                                                      static_cast<size_t>(nk) + 1);
    // (ind and v are written in every slot below; ptr(0) stays the zero of its initialisation)
    Matrix::local_graph_device_type::entries_type::non_const_type ind(
        Kokkos::ViewAllocateWithoutInitializing("A columns"), nnz);
    Matrix::local_matrix_device_type::values_type v(
        Kokkos::ViewAllocateWithoutInitializing("A values"), nnz);
    reserve_eighth(m.value_slot, nnz);
    m.value_slot.resize(nnz);
    std::vector<std::pair<LO, size_t>> row;  // (local column, position in kcols) of one row
    for (LO i = 0; i < nk; ++i) {
      const size_t b = start[static_cast<size_t>(i)], e = start[static_cast<size_t>(i) + 1];
      row.clear();
      for (size_t q = b; q < e; ++q) {
        const GO c = kcols[q];
        const LO lc = c >= rfirst && c < rfirst + nk
                          ? static_cast<LO>(c - rfirst)
                          : nk + static_cast<LO>(std::lower_bound(remote.begin(), remote.end(), c) -
                                                 remote.begin());
        row.emplace_back(lc, q);
      }
      std::sort(row.begin(), row.end());
      for (size_t j = 0; j < row.size(); ++j) {
        ind(b + j) = row[j].first;
        v(b + j) = kvals[row[j].second];
        m.value_slot[row[j].second] = b + j;
      }
      ptr(static_cast<size_t>(i) + 1) = e;
    }
    m.A = rcp(new Matrix(m.rmap, colmap, ptr, ind, v));
    m.A->expertStaticFillComplete(m.rmap, m.rmap);
    m.row_start = std::move(start);
    m.pattern = std::move(kcols);
    ++m.pattern_builds;
    m.prec = Teuchos::null;  // a preconditioner of another pattern is not reused (measured:
                             // lagged across free-surface flag changes it needs 2-3x the
                             // iterations, and the rebuilds it saves are lost again)
  }
  // where each merged entry of a kept row sits in Tpetra's values (repeat path), and the
  // slots of the kept rows without entries (their identity 1)
  m.pre_dest.assign(m.pre_start.back(), -1);
  m.one_slots.clear();
  const auto& kstart = m.row_start;  // equal to start when the pattern is the same
  for (size_t q = 0; q < m.kept.size(); ++q) {
    const int a = m.kept_rec[q];
    if (a < 0) {
      m.one_slots.push_back(m.value_slot[kstart[q]]);
      continue;
    }
    const size_t p0 = m.pre_start[static_cast<size_t>(a)];
    for (size_t j = 0; j < m.pre_start[static_cast<size_t>(a) + 1] - p0; ++j)
      m.pre_dest[p0 + j] = static_cast<long long>(m.value_slot[kstart[q] + j]);
  }
  m.rec_type = m.prec_type;
  m.rec_valid = true;
  m.update_staleness();
}

// Lagged preconditioner: rebuild unless it is recent enough and still effective (the last
// solve converged within 1.5 times the iterations of its first solve, plus 2).
void LinearSystem::Impl::update_staleness() {
  const int reuse = params.get<int>("Preconditioner reuse");
  ++prec_age;
  const bool effective =
      last_converged && fresh_iters >= 0 && last_iters <= (3 * fresh_iters) / 2 + 2;
  prec_stale = prec.is_null() || (prec_age > reuse && !held) || !effective || built_type != prec_type;
}

void LinearSystem::hold_preconditioner(bool hold) { impl_->held = hold; }

namespace {
using NO = Map::node_type;
using MueLuManager = MueLu::HierarchyManager<SC, LO, GO, NO>;

// MueLu's interpreter lowers its number of levels to the levels of the last hierarchy it set up
// (meant for reusing that hierarchy); set up from scratch each time, every hierarchy may again
// use the configured number (a first, tiny matrix would otherwise leave one level for good).
using MueLuInterpreter = MueLu::ParameterListInterpreter<SC, LO, GO, NO>;
using MueLuHierarchy = MueLu::Hierarchy<SC, LO, GO, NO>;
class FreshLevelsInterpreter : public MueLuInterpreter {
 public:
  FreshLevelsInterpreter(Teuchos::ParameterList& pl,
                         Teuchos::RCP<const Teuchos::Comm<int>> comm)
      : MueLuInterpreter(pl, comm), levels_(this->numDesiredLevel_) {}
  void SetupHierarchy(MueLuHierarchy& H) const override {
    this->numDesiredLevel_ = levels_;
    MueLuInterpreter::SetupHierarchy(H);
  }

 private:
  int levels_;
};

// `manager` caches MueLu's interpretation of the parameter list: MueLu::CreateTpetraPreconditioner
// parses and validates the list and builds its factories in every call, which took 45 % of the
// N-DAM chute's run time at 5 mm (a new preconditioner in every step). The same interpreter sets
// up each new hierarchy, as CreateXpetraPreconditioner does with a fresh one.
RCP<OP> build_preconditioner(const RCP<Matrix>& A, const std::string& type,
                             const ParameterList& p, RCP<MueLuManager>& manager,
                             double damping = 0.0) {
  if (type == "None") return Teuchos::null;
  if (type == "MueLu") {
    if (manager.is_null()) {
      ParameterList ml = p.sublist("MueLu");
      manager = rcp(new FreshLevelsInterpreter(ml, A->getDomainMap()->getComm()));
    }
    auto xA = MueLu::TpetraCrs_To_XpetraMatrix<SC, LO, GO, NO>(A);
    RCP<MueLu::Hierarchy<SC, LO, GO, NO>> H = manager->CreateHierarchy();
    H->setlib(Xpetra::UseTpetra);
    H->GetLevel(0)->Set("A", xA);
    H->SetProcRankVerbose(A->getDomainMap()->getComm()->getRank());
    manager->SetupHierarchy(*H);
    return rcp(new MueLu::TpetraOperator<SC, LO, GO, NO>(H));
  }
  // Ifpack2: "Ifpack2 RILUK" -> RILUK, "Ifpack2 RELAXATION" -> RELAXATION, ...
  const std::string kind = type.substr(type.find(' ') + 1);
  Ifpack2::Factory factory;
  RCP<const Tpetra::RowMatrix<SC>> Arow = A;
  auto P = factory.create<Tpetra::RowMatrix<SC>>(kind, Arow);
  ParameterList ip = p.sublist("Ifpack2");
  if (kind == "RELAXATION") {
    // Only the relaxation's own parameters (Relaxation validates its list; the sublist's
    // default holds RILUK's level of fill), and symmetric Gauss-Seidel unless told otherwise:
    // Ifpack2's default, Jacobi, is a poor preconditioner and CG needs a symmetric one.
    ParameterList rp("Ifpack2");
    rp.set("relaxation: type", "Symmetric Gauss-Seidel");
    for (auto it = ip.begin(); it != ip.end(); ++it)
      if (ip.name(it).rfind("relaxation:", 0) == 0) rp.setEntry(ip.name(it), ip.entry(it));
    // the model's damping factor (set_relaxation_damping) unless the list gives one
    if (damping > 0.0 && !rp.isParameter("relaxation: damping factor"))
      rp.set("relaxation: damping factor", damping);
    ip = rp;
  }
  P->setParameters(ip);
  P->initialize();
  P->compute();
  return P;
}
}  // namespace

double LinearSystem::Impl::rebuild_preconditioner() {
  const auto t0 = Clock::now();
  prec = build_preconditioner(A, prec_type, params, muelu, relax_damping);
  built_type = prec_type;
  prec_stale = false;
  prec_age = 0;
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  ++prec_setups;
  prec_setup_seconds += seconds;
  return seconds;
}

void LinearSystem::invalidate_preconditioner() {
  impl_->prec = Teuchos::null;
  impl_->prec_stale = true;
}

SolveStats LinearSystem::solve(const std::vector<double>& b, std::vector<double>& x) {
  auto& m = *impl_;
  if (m.A.is_null()) throw std::logic_error("LinearSystem::solve before end()");
  if (static_cast<LO>(b.size()) != m.nlocal || static_cast<LO>(x.size()) != m.nlocal)
    throw std::logic_error("LinearSystem::solve: vector size does not match the local rows");
  SolveStats st;
  st.stiff = m.params.isParameter("Stiff preconditioner") &&
             m.prec_type != m.params.get<std::string>("Preconditioner");
  // Trivial rows: x = b (rows without entries: copied between the kept rows), x = b / d (a
  // single diagonal entry). The Krylov system holds the kept rows only.
  {
    size_t from = 0;
    for (LO r : m.kept) {
      std::copy(b.begin() + static_cast<std::ptrdiff_t>(from), b.begin() + r,
                x.begin() + static_cast<std::ptrdiff_t>(from));
      from = static_cast<size_t>(r) + 1;
    }
    std::copy(b.begin() + static_cast<std::ptrdiff_t>(from), b.end(),
              x.begin() + static_cast<std::ptrdiff_t>(from));
    for (size_t t = 0; t < m.triv_rec.size(); ++t) {
      const size_t i = static_cast<size_t>(m.rec_rows[static_cast<size_t>(m.triv_rec[t])]);
      x[i] = b[i] / m.triv_d[t];
    }
  }
  if (m.rglobal == 0) {
    st.converged = true;
    ++solves_;
    return st;
  }
  const LO nk = static_cast<LO>(m.kept.size());
  bool fresh = m.prec_stale;
  if (m.prec_stale) st.setup_seconds = m.rebuild_preconditioner();
  auto t1 = Clock::now();
  // (both written in full below: no zero fill)
  auto B = rcp(new MV(m.rmap, 1, false));
  auto X = rcp(new MV(m.rmap, 1, false));
  {
    auto bv = B->getDataNonConst(0);
    auto xv = X->getDataNonConst(0);
    for (LO i = 0; i < nk; ++i) {
      bv[i] = b[static_cast<size_t>(m.kept[static_cast<size_t>(i)])];
      xv[i] = x[static_cast<size_t>(m.kept[static_cast<size_t>(i)])];
    }
  }
  // A zero right-hand side has the solution zero (Belos would report a 0/0 residual).
  Teuchos::Array<SC> bnorm(1);
  B->norm2(bnorm());
  if (bnorm[0] == 0.0) {
    for (LO i = 0; i < nk; ++i) x[static_cast<size_t>(m.kept[static_cast<size_t>(i)])] = 0.0;
    st.converged = true;
    st.solve_seconds = std::chrono::duration<double>(Clock::now() - t1).count();
    m.krylov_seconds += st.solve_seconds;
    ++solves_;
    return st;
  }
  auto bp = rcp(new ParameterList("Belos"));
  bp->set("Convergence Tolerance", m.params.get<double>("Tolerance"));
  // A held preconditioner (hold_preconditioner) is worth keeping only while it does about as
  // well as a fresh one: its solve stops after 4 n_fresh + 20 iterations (n_fresh: the first
  // solve with it) and is repeated with a fresh one. Without the cap a held preconditioner
  // that had gone bad ran to the limit first (Setup II at 2.6 mm in the deposit at 1.45 s,
  // where nu_eff jumps between trial pressures: solves of up to 978 iterations, 30x the cost
  // of an evaluation). A cap of 2 n + 10 repeated 682 of the 8900 momentum solves of Setup II
  // at 2.6 mm to 0.75 s, 4 n + 20 repeats 23.
  const int max_iterations = m.params.get<int>("Max iterations");
  const bool capped = !fresh && m.held && m.fresh_iters >= 0 &&
                      4 * m.fresh_iters + 20 < max_iterations;
  bp->set("Maximum Iterations", capped ? 4 * m.fresh_iters + 20 : max_iterations);
  bp->set("Verbosity", 0);
  // Relative to ||b|| (Belos' default scales by the preconditioned initial residual).
  bp->set("Implicit Residual Scaling", "Norm of RHS");
  bp->set("Explicit Residual Scaling", "Norm of RHS");
  const auto solver_name = m.params.get<std::string>("Solver");
  if (solver_name == "GMRES") {
    bp->set("Num Blocks", m.params.get<int>("GMRES restart"));
    bp->set("Maximum Restarts", 1000);
  }
  Belos::SolverFactory<SC, MV, OP> factory;
  auto solver = factory.create(solver_name, bp);
  RCP<OP> Aop = m.A;
  auto set_problem = [&] {
    auto problem = rcp(new Belos::LinearProblem<SC, MV, OP>(Aop, X, B));
    if (!m.prec.is_null()) problem->setLeftPrec(m.prec);
    problem->setProblem();
    solver->setProblem(problem);
  };
  set_problem();
  Belos::ReturnType r = Belos::Unconverged;
  try {
    r = solver->solve();
    if (r != Belos::Converged && !fresh) {
      // A kept (lagged or held) preconditioner that no longer suits the matrix: build one for
      // it and solve again from the same initial guess, so that reuse never costs convergence.
      const int lagged_iters = solver->getNumIters();
      st.setup_seconds += m.rebuild_preconditioner();
      ++m.prec_retries;
      {
        auto xv = X->getDataNonConst(0);
        for (LO i = 0; i < nk; ++i) xv[i] = x[static_cast<size_t>(m.kept[static_cast<size_t>(i)])];
      }
      if (capped) {
        bp->set("Maximum Iterations", max_iterations);
        solver = factory.create(solver_name, bp);
      }
      set_problem();
      r = solver->solve();
      total_iterations_ += lagged_iters;
      fresh = true;
    }
  } catch (const std::exception&) {
    // Belos throws on NaN/Inf in the residual: report an unconverged solve with a non-finite
    // solution, so that the model's check() stops the run with a diagnosis.
    std::fill(x.begin(), x.end(), std::numeric_limits<double>::quiet_NaN());
    st.iterations = solver->getNumIters();
    st.residual = std::numeric_limits<double>::quiet_NaN();
    st.solve_seconds = std::chrono::duration<double>(Clock::now() - t1).count();
    m.krylov_seconds += st.solve_seconds;
    ++solves_;
    return st;
  }
  st.iterations = solver->getNumIters();
  // True relative residual (Belos' achievedTol is the preconditioned one for left
  // preconditioning).
  MV R(m.rmap, 1, false);  // (apply overwrites it)
  m.A->apply(*X, R);
  R.update(1.0, *B, -1.0);
  Teuchos::Array<SC> rnorm(1);
  R.norm2(rnorm());
  st.residual = rnorm[0] / bnorm[0];
  st.converged = r == Belos::Converged;
  if (fresh) m.fresh_iters = st.iterations;
  m.last_iters = st.iterations;
  m.last_converged = st.converged;
  {
    auto xv = X->getData(0);
    for (LO i = 0; i < nk; ++i) x[static_cast<size_t>(m.kept[static_cast<size_t>(i)])] = xv[i];
  }
  st.solve_seconds = std::chrono::duration<double>(Clock::now() - t1).count();
  m.krylov_seconds += st.solve_seconds;
  total_iterations_ += st.iterations;
  ++solves_;
  return st;
}

Teuchos::RCP<const ParameterList> LinearSystem::getValidParameters(
    const std::string& name, const std::string& solver, const std::string& preconditioner,
    double tolerance) {
  using namespace params;
  auto pl = rcp(new ParameterList(name));
  add_enum(*pl, "Solver", solver,
           "Belos Krylov method: CG (symmetric positive definite systems: the pressure "
           "equation and the implicit viscous stress), GMRES, BICGSTAB",
           {"CG", "GMRES", "BICGSTAB"});
  add_enum(*pl, "Preconditioner", preconditioner,
           "MueLu (smoothed-aggregation AMG, settings in the MueLu sublist), Ifpack2 RILUK "
           "(incomplete LU, level from the Ifpack2 sublist), Ifpack2 RELAXATION (Jacobi/"
           "Gauss-Seidel sweeps), or None",
           kPreconditioners);
  add_double(*pl, "Tolerance", tolerance,
             "relative residual ||b - A x|| / ||b|| at which the Krylov iteration stops", 1e-16,
             1e-1);
  add_int(*pl, "Max iterations", 1000, "Krylov iterations before the solve is reported failed",
          1, 1000000);
  add_int(*pl, "Preconditioner reuse", 10,
          "assemblies of the same sparsity pattern for which a preconditioner may be reused "
          "(lagged) before it is rebuilt; it is rebuilt earlier when a solve does not converge "
          "or needs more than 1.5 times (+2) the iterations of its first solve. 0: rebuild "
          "after every assembly",
          0, 1000000);
  add_int(*pl, "GMRES restart", 50, "Krylov vectors kept between GMRES restarts", 1, 10000);
  // Pass-through lists: validated by MueLu/Ifpack2 themselves, not by us.
  ParameterList ml = default_muelu();
  // MueLu validates its list itself, nested lists included ("smoother: params" takes the
  // parameters of whichever smoother "smoother: type" names)
  ml.disableRecursiveValidation();
  ml.sublist("coarse: params").disableRecursiveValidation();
  ml.sublist("smoother: params").disableRecursiveValidation();
  pl->set("MueLu", ml,
          "parameters handed to MueLu::CreateTpetraPreconditioner as they are (MueLu's own "
          "names; see the MueLu user guide). Defaults: smoothed aggregation, one symmetric "
          "Gauss-Seidel sweep, relaxation coarse solve");
  ParameterList ip("Ifpack2");
  ip.set("fact: iluk level-of-fill", 1);
  ip.disableRecursiveValidation();
  pl->set("Ifpack2", ip,
          "parameters handed to the Ifpack2 preconditioner as they are (Ifpack2's own names)");
  return pl;
}

void LinearSystem::add_stiff_switch(ParameterList& pl, const std::string& preconditioner,
                                    double threshold, const std::string& meaning) {
  using namespace params;
  add_enum(pl, "Stiff preconditioner", preconditioner,
           "preconditioner (the values of Preconditioner) of the assemblies whose stiffness "
           "reaches 'Stiff threshold'; stiffness: " + meaning,
           kPreconditioners);
  add_double(pl, "Stiff threshold", threshold,
             "stiffness from which on 'Stiff preconditioner' replaces 'Preconditioner' (0: "
             "always; a value above any stiffness: never)",
             0.0, 1e300);
}

namespace {
// The first lines of a Trilinos exception that say what is wrong (params::trim_teuchos), at
// most six, without the list of every valid parameter that an unknown name brings along.
std::string trilinos_reason(const std::string& what) {
  std::string out = params::trim_teuchos(what.substr(0, what.find("The valid parameters and types are")));
  std::size_t end = 0;
  for (int n = 0; n < 6 && end != std::string::npos; ++n) end = out.find('\n', end + (n > 0));
  if (end != std::string::npos) out.erase(end);
  out.erase(0, out.find_first_not_of(' '));
  return out.empty() ? what : out;
}

// The MueLu and Ifpack2 lists pass through to Trilinos unvalidated by us (their own names):
// a bad name or value there surfaced only when the run built its first preconditioner, as
// exit 4 with a Trilinos dump, sometimes after several steps (a hostile-user run: "smoother:
// type" = BOGUS, "fact: iluk level-of-fill" = -1), while --check called the scene valid. Each
// configured preconditioner is built once, at input, on a small model matrix (the 2D
// five-point Laplacian of 12 x 12 cells, on this rank alone), and a failure names its list.
void trial_build(const ParameterList& p, const std::string& type) {
  if (type == "None") return;
  int mpi = 0;  // a reader of configurations without MPI (a unit test) builds no preconditioner
  MPI_Initialized(&mpi);
  // RILUK takes a negative level of fill without a word and fails only on a matrix whose
  // pattern needs fill (the run's momentum matrix after 7 steps): checked here
  if (type == "Ifpack2 RILUK" && p.isSublist("Ifpack2") &&
      p.sublist("Ifpack2").isType<int>("fact: iluk level-of-fill") &&
      p.sublist("Ifpack2").get<int>("fact: iluk level-of-fill") < 0)
    params::fail(p.sublist("Ifpack2"), "fact: iluk level-of-fill",
                 std::to_string(p.sublist("Ifpack2").get<int>("fact: iluk level-of-fill")),
                 "the level of fill of the incomplete LU; allowed: an integer >= 0");
  // A damping factor outside (0, 2) makes (symmetric) Gauss-Seidel diverge or, at 0, divide
  // by zero; Ifpack2 takes it without a word (found when the N-DAM pressure made relaxation
  // its default)
  if (type == "Ifpack2 RELAXATION" && p.isSublist("Ifpack2") &&
      p.sublist("Ifpack2").isType<double>("relaxation: damping factor")) {
    const double w = p.sublist("Ifpack2").get<double>("relaxation: damping factor");
    if (!(w > 0.0 && w < 2.0))
      params::fail(p.sublist("Ifpack2"), "relaxation: damping factor", params::str(w),
                   "the relaxation's damping factor omega; allowed: 0 < omega < 2");
  }
  if (!mpi) return;
  const auto comm = rcp(new Teuchos::MpiComm<int>(MPI_COMM_SELF));
  constexpr int n = 12;
  auto map = rcp(new Map(static_cast<Tpetra::global_size_t>(n * n), 0, comm));
  auto A = rcp(new Matrix(map, 5));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const GO r = j * n + i;
      std::vector<GO> cols{r};
      std::vector<SC> vals{4.0};
      if (i > 0) cols.push_back(r - 1), vals.push_back(-1.0);
      if (i + 1 < n) cols.push_back(r + 1), vals.push_back(-1.0);
      if (j > 0) cols.push_back(r - n), vals.push_back(-1.0);
      if (j + 1 < n) cols.push_back(r + n), vals.push_back(-1.0);
      A->insertGlobalValues(r, Teuchos::arrayViewFromVector(cols),
                            Teuchos::arrayViewFromVector(vals));
    }
  A->fillComplete();
  ParameterList q = p;
  q.set("MueLu", merged_muelu(p));
  q.sublist("MueLu").set("number of equations", 1);  // the model matrix is scalar
  RCP<MueLuManager> manager;
  try {
    build_preconditioner(A, type, q, manager);
  } catch (const std::exception& e) {
    const std::string list = type == "MueLu" ? "MueLu" : "Ifpack2";
    params::fail(p, list, "{...}",
                 "the " + type + " preconditioner cannot be built with these settings (tried on "
                 "a model matrix at input): " + trilinos_reason(e.what()) +
                 "; allowed: the names and values of the " + list + " user guide");
  }
}
}  // namespace

void LinearSystem::check(const ParameterList& p, int ranks) {
  trial_build(p, p.get<std::string>("Preconditioner"));
  if (p.isParameter("Stiff preconditioner") &&
      p.get<std::string>("Stiff preconditioner") != p.get<std::string>("Preconditioner"))
    trial_build(p, p.get<std::string>("Stiff preconditioner"));
  const bool muelu = p.get<std::string>("Preconditioner") == "MueLu" ||
                     (p.isParameter("Stiff preconditioner") &&
                      p.get<std::string>("Stiff preconditioner") == "MueLu");
  if (!muelu || ranks <= 1) return;
  const auto merged = merged_muelu(p);
  const auto& ml = p.isSublist("MueLu") ? p.sublist("MueLu") : merged;
  const std::string c = merged.get<std::string>("coarse: type");
  std::string lc = c;
  std::transform(lc.begin(), lc.end(), lc.begin(), ::tolower);
  if (lc != "relaxation" && lc != "chebyshev")
    params::fail(ml, "coarse: type", c,
                 "direct coarse solvers (Amesos2 KLU2) give wrong solutions on more than one "
                 "MPI rank with this Trilinos; allowed: RELAXATION or CHEBYSHEV");
}

}  // namespace granflow::solvers
