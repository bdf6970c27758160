// NOX (through Thyra and Stratimikos) on Tpetra behind solvers::NonlinearSystem. Together with
// linear_system.cpp the only translation units that include Trilinos solver headers
// (this one: NOX + Thyra + Stratimikos + MueLu + Ifpack2, ~30 s to compile at -O3).
//
// Structure, and why (facts measured on Debian 12's Trilinos 13.2: shared/TRILINOS-NOTES.md):
// - The model is a Thyra::StateFuncModelEvaluatorBase on a Tpetra vector space. It evaluates
//   f (the residual callback), W_op (analytic Jacobian from the matrix callback, behind a proxy
//   Tpetra operator whose matrix is swapped at every evaluation) and W_prec.
// - The preconditioner always comes from the model's W_prec (built here with MueLu or Ifpack2
//   from the matrix callback), and Stratimikos is configured with "Preconditioner Type" = "None".
//   For JFNK this is required (a Stratimikos preconditioner factory would be handed the
//   matrix-free operator); for the analytic Jacobian it keeps one code path and avoids
//   registering Ifpack2 by hand (Debian's Stratimikos lacks it). The preconditioner is applied
//   from the right, so Belos' residual is the true linear residual.
// - JFNK: NOX::Thyra::MatrixFreeJacobianOperator (forward differences, "KSP NOX 2001"
//   perturbation, lambda = 1e-4 by default: 1e-6 diverged here) with the model wrapped in
//   NOX::MatrixFreeModelEvaluatorDecorator.
// - MueLu's coarse solve is RELAXATION: Amesos2 KLU2 is wrong on more than one rank here.
// - Every collective decision (reuse of a matrix graph, of a cached matrix) is agreed on by an
//   MPI reduction, so that ranks never take different collective paths.
#include "granflow/solvers/nonlinear_system.hpp"

#include "granflow/params/parameters.hpp"

#include <Ifpack2_Factory.hpp>
#include <MueLu_CreateTpetraPreconditioner.hpp>
#include <NOX.H>
#include <NOX_MatrixFree_ModelEvaluatorDecorator.hpp>
#include <NOX_Observer.hpp>
#include <NOX_Thyra.H>
#include <NOX_Thyra_MatrixFreeJacobianOperator.hpp>
#include <Stratimikos_DefaultLinearSolverBuilder.hpp>
#include <Teuchos_oblackholestream.hpp>
#include <Teuchos_DefaultMpiComm.hpp>
#include <Thyra_DefaultPreconditioner.hpp>
#include <Thyra_StateFuncModelEvaluatorBase.hpp>
#include <Thyra_TpetraLinearOp.hpp>
#include <Thyra_TpetraThyraWrappers.hpp>
#include <Tpetra_Core.hpp>
#include <Tpetra_CrsMatrix.hpp>
#include <Tpetra_Vector.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace granflow::solvers {

namespace {

using SC = double;
using LO = Tpetra::Map<>::local_ordinal_type;
using GO = Tpetra::Map<>::global_ordinal_type;
using NO = Tpetra::Map<>::node_type;
using Map = Tpetra::Map<>;
using CrsMatrix = Tpetra::CrsMatrix<SC>;
using TVector = Tpetra::Vector<SC>;
using TMV = Tpetra::MultiVector<SC>;
using TOp = Tpetra::Operator<SC>;
using TOE = Thyra::TpetraOperatorVectorExtraction<SC, LO, GO, NO>;
using Clock = std::chrono::steady_clock;
using Teuchos::ParameterList;
using Teuchos::RCP;
using Teuchos::rcp;

const char* const kAnalytic = "Newton-Krylov (analytic Jacobian)";
const char* const kJFNK = "Jacobian-free Newton-Krylov";

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

ParameterList default_muelu() {
  ParameterList ml("MueLu");
  ml.set("verbosity", "none");
  ml.set("multigrid algorithm", "sa");
  ml.set("coarse: type", "RELAXATION",
         "not KLU2/Klu: Amesos2 KLU2 is wrong on more than one rank in Debian's Trilinos 13.2");
  ParameterList cp("coarse: params");
  cp.set("relaxation: type", "Symmetric Gauss-Seidel");
  cp.set("relaxation: sweeps", 4);
  ml.set("coarse: params", cp);
  ml.set("coarse: max size", 200);
  ml.set("smoother: type", "RELAXATION");
  ParameterList sp("smoother: params");
  sp.set("relaxation: type", "Symmetric Gauss-Seidel");
  sp.set("relaxation: sweeps", 1);
  ml.set("smoother: params", sp);
  return ml;
}

// The analytic Jacobian as NOX sees it: a fixed Tpetra operator (Thyra wraps it once) whose
// matrix is replaced at each W_op evaluation.
class MatrixProxy : public TOp {
 public:
  explicit MatrixProxy(RCP<const Map> map) : map_(std::move(map)) {}
  void set(RCP<const CrsMatrix> A) { A_ = std::move(A); }
  RCP<const Map> getDomainMap() const override { return map_; }
  RCP<const Map> getRangeMap() const override { return map_; }
  bool hasTransposeApply() const override { return true; }
  void apply(const TMV& X, TMV& Y, Teuchos::ETransp mode = Teuchos::NO_TRANS,
             SC alpha = Teuchos::ScalarTraits<SC>::one(),
             SC beta = Teuchos::ScalarTraits<SC>::zero()) const override {
    if (A_.is_null())
      throw std::logic_error("NonlinearSystem: Jacobian applied before it was evaluated");
    A_->apply(X, Y, mode, alpha, beta);
  }

 private:
  RCP<const Map> map_;
  RCP<const CrsMatrix> A_;
};

// ||F|| after every Newton step (collective: getNormF reduces over ranks).
class HistoryObserver : public NOX::Observer {
 public:
  explicit HistoryObserver(std::vector<double>* h) : h_(h) {}
  void runPostIterate(const NOX::Solver::Generic& solver) override {
    h_->push_back(solver.getSolutionGroup().getNormF());
  }

 private:
  std::vector<double>* h_;
};

// The state of a NonlinearSystem (Impl derives from it; the model evaluator sees it const).
struct Core {
  using Residual = NonlinearSystem::Residual;
  using Matrix = NonlinearSystem::Matrix;
  RCP<const Teuchos::Comm<int>> comm;
  MPI_Comm mpi_comm = MPI_COMM_NULL;
  RCP<const Map> map;
  RCP<const Thyra::VectorSpaceBase<SC>> space;
  GO first = 0;
  LO nlocal = 0;
  ParameterList params;
  Residual residual;
  Matrix matrix;
  bool jfnk = false;

  // buffers and the cached matrix (assembled at x_matrix)
  mutable std::vector<double> xbuf, fbuf, x_matrix;
  mutable Triplets trip;
  mutable RCP<CrsMatrix> A;
  mutable bool have_matrix = false;
  mutable std::vector<size_t> row_start;
  mutable std::vector<GO> pattern;
  mutable NonlinearStats* stats = nullptr;  // of the running solve

  bool all_ranks(bool local) const {
    int v = local ? 1 : 0, g = 0;
    MPI_Allreduce(&v, &g, 1, MPI_INT, MPI_MIN, mpi_comm);
    return g == 1;
  }

  void copy_in(const RCP<const Thyra::VectorBase<SC>>& x) const {
    auto xt = TOE::getConstTpetraVector(x);
    auto d = xt->getData();
    xbuf.resize(static_cast<size_t>(nlocal));
    for (LO i = 0; i < nlocal; ++i) xbuf[static_cast<size_t>(i)] = d[i];
  }

  void eval_residual(const RCP<Thyra::VectorBase<SC>>& f) const {
    fbuf.assign(static_cast<size_t>(nlocal), 0.0);
    residual(xbuf, fbuf);
    if (static_cast<LO>(fbuf.size()) != nlocal)
      throw std::logic_error("NonlinearSystem: the residual callback resized F");
    auto ft = TOE::getTpetraVector(f);
    auto d = ft->getDataNonConst();
    for (LO i = 0; i < nlocal; ++i) d[i] = fbuf[static_cast<size_t>(i)];
    if (stats) ++stats->residual_evaluations;
  }

  // The matrix at xbuf (from the callback unless the cached one was assembled at the same x on
  // every rank).
  RCP<CrsMatrix> matrix_at_x() const {
    if (all_ranks(have_matrix && x_matrix == xbuf)) return A;
    const auto t0 = Clock::now();
    trip.clear();
    matrix(xbuf, trip);
    if (stats) ++stats->matrix_evaluations;
    if (trip.rows.size() != trip.values.size() || trip.cols.size() != trip.values.size())
      throw std::logic_error("NonlinearSystem: triplet arrays of different lengths");
    // CSR of the owned rows: counting sort by row, then sort and merge within each row.
    std::vector<size_t> start(static_cast<size_t>(nlocal) + 1, 0);
    for (size_t k = 0; k < trip.size(); ++k) {
      const long long lr = trip.rows[k] - first;
      if (lr < 0 || lr >= nlocal)
        throw std::logic_error("NonlinearSystem: matrix callback gave row " +
                               std::to_string(trip.rows[k]) + ", not owned by this rank");
      ++start[static_cast<size_t>(lr) + 1];
    }
    for (LO i = 0; i < nlocal; ++i) start[i + 1] += start[i];
    std::vector<std::pair<GO, SC>> ent(trip.size());
    {
      std::vector<size_t> pos(start.begin(), start.end() - 1);
      for (size_t k = 0; k < trip.size(); ++k)
        ent[pos[static_cast<size_t>(trip.rows[k] - first)]++] = {trip.cols[k], trip.values[k]};
    }
    std::vector<size_t> cstart(static_cast<size_t>(nlocal) + 1, 0);
    std::vector<GO> cols;
    std::vector<SC> vals;
    cols.reserve(ent.size());
    vals.reserve(ent.size());
    for (LO i = 0; i < nlocal; ++i) {
      auto b = ent.begin() + static_cast<long>(start[i]);
      auto e = ent.begin() + static_cast<long>(start[i + 1]);
      std::sort(b, e, [](const auto& a, const auto& c) { return a.first < c.first; });
      const size_t row_begin = cols.size();
      for (auto it = b; it != e; ++it) {
        if (cols.size() > row_begin && cols.back() == it->first)
          vals.back() += it->second;
        else {
          cols.push_back(it->first);
          vals.push_back(it->second);
        }
      }
      cstart[i + 1] = cols.size();
    }
    const bool same = all_ranks(!A.is_null() && cstart == row_start && cols == pattern);
    RCP<CrsMatrix> M;
    if (same) {
      // New values on the old graph (a lagged preconditioner may still refer to the old A).
      M = rcp(new CrsMatrix(A->getCrsGraph()));
      for (LO i = 0; i < nlocal; ++i) {
        const auto b = cstart[i], e = cstart[i + 1];
        M->replaceGlobalValues(first + i, Teuchos::ArrayView<const GO>(cols.data() + b, e - b),
                               Teuchos::ArrayView<const SC>(vals.data() + b, e - b));
      }
      M->fillComplete();
    } else {
      Teuchos::Array<size_t> nnz(static_cast<size_t>(nlocal));
      for (LO i = 0; i < nlocal; ++i) nnz[i] = cstart[i + 1] - cstart[i];
      M = rcp(new CrsMatrix(map, nnz()));
      for (LO i = 0; i < nlocal; ++i) {
        const auto b = cstart[i], e = cstart[i + 1];
        M->insertGlobalValues(first + i, Teuchos::ArrayView<const GO>(cols.data() + b, e - b),
                              Teuchos::ArrayView<const SC>(vals.data() + b, e - b));
      }
      M->fillComplete();
      row_start = std::move(cstart);
      pattern = std::move(cols);
    }
    A = M;
    x_matrix = xbuf;
    have_matrix = true;
    if (stats) stats->preconditioner_seconds += seconds_since(t0);
    return A;
  }

  RCP<TOp> build_preconditioner(const RCP<CrsMatrix>& M) const {
    const auto t0 = Clock::now();
    const auto type = params.get<std::string>("Preconditioner");
    RCP<TOp> P;
    if (type == "MueLu") {
      ParameterList ml = default_muelu();
      ml.setParameters(params.sublist("MueLu"));
      RCP<TOp> Mop = M;
      P = MueLu::CreateTpetraPreconditioner(Mop, ml);
    } else if (type != "None") {
      const std::string kind = type.substr(type.find(' ') + 1);  // "Ifpack2 RILUK" -> RILUK
      Ifpack2::Factory factory;
      RCP<const Tpetra::RowMatrix<SC>> Mrow = M;
      auto prec = factory.create<Tpetra::RowMatrix<SC>>(kind, Mrow);
      // Ifpack2 rejects parameters of other methods, so the level-of-fill default is added
      // only for RILUK.
      ParameterList ip = params.sublist("Ifpack2");
      if (kind == "RILUK" && !ip.isParameter("fact: iluk level-of-fill"))
        ip.set("fact: iluk level-of-fill", 1);
      prec->setParameters(ip);
      prec->initialize();
      prec->compute();
      P = prec;
    }
    if (stats) {
      stats->preconditioner_seconds += seconds_since(t0);
      ++stats->preconditioner_builds;
    }
    return P;
  }
};

}  // namespace

struct NonlinearSystem::Impl : Core {};

namespace {

class Model : public Thyra::StateFuncModelEvaluatorBase<SC> {
 public:
  explicit Model(const Core* impl) : m_(impl) {
    Thyra::ModelEvaluatorBase::InArgsSetup<SC> in;
    in.setModelEvalDescription(this->description());
    in.setSupports(Thyra::ModelEvaluatorBase::IN_ARG_x);
    in_args_ = in;
    nominal_ = in;
    auto x0 = Thyra::createMember(m_->space);
    Thyra::V_S(x0.ptr(), 0.0);
    nominal_.set_x(x0);
    Thyra::ModelEvaluatorBase::OutArgsSetup<SC> out;
    out.setModelEvalDescription(this->description());
    out.setSupports(Thyra::ModelEvaluatorBase::OUT_ARG_f);
    out.setSupports(Thyra::ModelEvaluatorBase::OUT_ARG_W_op);
    out.setSupports(Thyra::ModelEvaluatorBase::OUT_ARG_W_prec);
    out_args_ = out;
  }
  RCP<const Thyra::VectorSpaceBase<SC>> get_x_space() const override { return m_->space; }
  RCP<const Thyra::VectorSpaceBase<SC>> get_f_space() const override { return m_->space; }
  Thyra::ModelEvaluatorBase::InArgs<SC> getNominalValues() const override { return nominal_; }
  Thyra::ModelEvaluatorBase::InArgs<SC> createInArgs() const override { return in_args_; }
  RCP<Thyra::LinearOpBase<SC>> create_W_op() const override {
    RCP<TOp> proxy = rcp(new MatrixProxy(m_->map));
    return Thyra::tpetraLinearOp<SC, LO, GO, NO>(m_->space, m_->space, proxy);
  }
  RCP<Thyra::PreconditionerBase<SC>> create_W_prec() const override {
    return rcp(new Thyra::DefaultPreconditioner<SC>);
  }
  RCP<const Thyra::LinearOpWithSolveFactoryBase<SC>> get_W_factory() const override {
    return Teuchos::null;
  }

 private:
  Thyra::ModelEvaluatorBase::OutArgs<SC> createOutArgsImpl() const override { return out_args_; }

  void evalModelImpl(const Thyra::ModelEvaluatorBase::InArgs<SC>& in,
                     const Thyra::ModelEvaluatorBase::OutArgs<SC>& out) const override {
    m_->copy_in(in.get_x());
    const auto f = out.get_f();
    if (!f.is_null()) m_->eval_residual(f);
    const auto W = out.get_W_op();
    if (!W.is_null()) {
      auto proxy = Teuchos::rcp_dynamic_cast<MatrixProxy>(TOE::getTpetraOperator(W), true);
      proxy->set(m_->matrix_at_x());
    }
    const auto Wp = out.get_W_prec();
    if (!Wp.is_null()) {
      auto prec = Teuchos::rcp_dynamic_cast<Thyra::DefaultPreconditioner<SC>>(Wp, true);
      auto P = m_->build_preconditioner(m_->matrix_at_x());
      if (!P.is_null())
        prec->initializeRight(RCP<Thyra::LinearOpBase<SC>>(
            Thyra::tpetraLinearOp<SC, LO, GO, NO>(m_->space, m_->space, P)));
      else
        prec->uninitialize();
    }
  }

  const Core* m_;
  Thyra::ModelEvaluatorBase::InArgs<SC> in_args_, nominal_;
  Thyra::ModelEvaluatorBase::OutArgs<SC> out_args_;
};

std::string fmt(double v) {
  std::ostringstream s;
  s.precision(3);
  s << std::scientific << v;
  return s.str();
}

}  // namespace

NonlinearSystem::NonlinearSystem(MPI_Comm comm, long long global_rows, long long first_row,
                                 int local_rows, const ParameterList& params, Residual residual,
                                 Matrix matrix)
    : impl_(std::make_unique<Impl>()) {
  auto& m = *impl_;
  m.mpi_comm = comm;
  m.comm = rcp(new Teuchos::MpiComm<int>(comm));
  m.first = first_row;
  m.nlocal = local_rows;
  m.params = params;
  m.params.setName("Nonlinear solver");
  params::validate_and_set_defaults(m.params, *getValidParameters(), "Nonlinear solver");
  m.jfnk = m.params.get<std::string>("Method") == kJFNK;
  if (!residual) throw std::logic_error("NonlinearSystem: no residual callback");
  if (!matrix && (!m.jfnk || m.params.get<std::string>("Preconditioner") != "None"))
    throw std::logic_error("NonlinearSystem: no matrix callback (needed for the Jacobian or "
                           "the preconditioner)");
  m.residual = std::move(residual);
  m.matrix = std::move(matrix);
  m.map = rcp(new Map(static_cast<Tpetra::global_size_t>(global_rows),
                      static_cast<size_t>(local_rows), 0, m.comm));
  if (local_rows > 0 && m.map->getMinGlobalIndex() != first_row)
    throw std::logic_error("NonlinearSystem: rows must be numbered in rank order");
  m.space = Thyra::createVectorSpace<SC, LO, GO, NO>(m.map);
}

NonlinearSystem::~NonlinearSystem() = default;

long long NonlinearSystem::global_rows() const {
  return static_cast<long long>(impl_->map->getGlobalNumElements());
}
int NonlinearSystem::local_rows() const { return impl_->nlocal; }

NonlinearStats NonlinearSystem::solve(std::vector<double>& p) {
  auto& m = *impl_;
  const auto& P = m.params;
  if (static_cast<LO>(p.size()) != m.nlocal)
    throw std::logic_error("NonlinearSystem::solve: p does not have local_rows entries");
  NonlinearStats st;
  const auto t0 = Clock::now();
  m.stats = &st;
  m.have_matrix = false;  // p may be a new problem (new time step): never reuse across solves
  struct Reset {
    Impl& m;
    ~Reset() { m.stats = nullptr; }
  } reset{m};

  try {
    auto model = rcp(new Model(&m));

    // Linear solver: Belos through Stratimikos; the preconditioner comes from W_prec.
    Stratimikos::DefaultLinearSolverBuilder builder;
    auto sp = Teuchos::parameterList("Stratimikos");
    sp->set("Linear Solver Type", "Belos");
    auto& bl = sp->sublist("Linear Solver Types").sublist("Belos");
    const bool cg = P.get<std::string>("Krylov solver") == "CG";
    const std::string belos_type = cg ? "Pseudo Block CG" : "Pseudo Block GMRES";
    bl.set("Solver Type", belos_type);
    auto& bs = bl.sublist("Solver Types").sublist(belos_type);
    bs.set("Maximum Iterations", P.get<int>("Max Krylov iterations"));
    if (!cg) bs.set("Num Blocks", P.get<int>("GMRES restart"));
    bs.set("Verbosity", 0);
    bl.sublist("VerboseObject").set("Verbosity Level", "none");
    sp->set("Preconditioner Type", "None");
    builder.setParameterList(sp);
    RCP<Thyra::LinearOpWithSolveFactoryBase<SC>> lows = builder.createLinearSolveStrategy("");

    // Initial guess
    auto x0 = Thyra::createMember(m.space);
    {
      auto xt = TOE::getTpetraVector(x0);
      auto d = xt->getDataNonConst();
      for (LO i = 0; i < m.nlocal; ++i) d[i] = p[static_cast<size_t>(i)];
    }
    NOX::Thyra::Vector nox_x0(x0);

    const bool want_prec = P.get<std::string>("Preconditioner") != "None";
    const bool reuse_prec = P.get<bool>("Reuse preconditioner");
    ParameterList print_params;
    print_params.set("Output Processor", 0);
    print_params.set("MyPID", m.comm->getRank());
    RCP<NOX::Thyra::Group> group;
    RCP<NOX::Thyra::MatrixFreeJacobianOperator<SC>> jfnk_op;
    RCP<Thyra::PreconditionerBase<SC>> prec =
        want_prec ? model->create_W_prec() : RCP<Thyra::PreconditionerBase<SC>>();
    if (want_prec && reuse_prec) {
      // Built once, at p0, and frozen for this solve.
      auto in = model->createInArgs();
      in.set_x(x0);
      auto out = model->createOutArgs();
      out.set_W_prec(prec);
      model->evalModel(in, out);
    }
    const RCP<Thyra::PreconditionerFactoryBase<SC>> no_prec_factory;
    const RCP<const Thyra::VectorBase<SC>> no_weight;
    const RCP<Thyra::VectorBase<SC>> no_inv_weight;
    if (m.jfnk) {
      auto jp = Teuchos::parameterList("Matrix-free Jacobian");
      jp->set("Difference Type", "Forward");
      jp->set("Perturbation Algorithm", "KSP NOX 2001");
      jp->set("lambda", P.get<double>("FD lambda"));
      jfnk_op = rcp(new NOX::Thyra::MatrixFreeJacobianOperator<SC>(print_params));
      jfnk_op->setParameterList(jp);
      RCP<Thyra::ModelEvaluator<SC>> mf_model =
          rcp(new NOX::MatrixFreeModelEvaluatorDecorator<SC>(model));
      group = rcp(new NOX::Thyra::Group(nox_x0, mf_model, jfnk_op, lows, prec, no_prec_factory,
                                        no_weight, no_weight, no_inv_weight, false,
                                        !reuse_prec));
    } else {
      RCP<Thyra::LinearOpBase<SC>> W = model->create_W_op();
      group = rcp(new NOX::Thyra::Group(nox_x0, model, W, lows, prec, no_prec_factory,
                                        no_weight, no_weight, no_inv_weight, false,
                                        !reuse_prec));
    }
    group->computeF();
    if (m.jfnk) jfnk_op->setBaseEvaluationToNOXGroup(group.create_weak());
    st.initial_residual = group->getNormF();
    st.residual_history.push_back(st.initial_residual);

    // Status tests: converged when ||F||_2 <= atol or <= rtol ||F0||_2; stop on a non-finite
    // ||F|| or after the maximum number of Newton steps.
    const double atol = P.get<double>("Absolute tolerance");
    const double rtol = P.get<double>("Relative tolerance");
    const int maxit = P.get<int>("Max Newton iterations");
    auto abs_test = rcp(new NOX::StatusTest::NormF(atol, NOX::StatusTest::NormF::Unscaled));
    auto rel_test =
        rcp(new NOX::StatusTest::NormF(*group, rtol, NOX::StatusTest::NormF::Unscaled));
    auto conv = rcp(new NOX::StatusTest::Combo(NOX::StatusTest::Combo::OR));
    conv->addStatusTest(abs_test);
    conv->addStatusTest(rel_test);
    auto max_test = rcp(new NOX::StatusTest::MaxIters(maxit));
    auto fv_test = rcp(new NOX::StatusTest::FiniteValue);
    auto all = rcp(new NOX::StatusTest::Combo(NOX::StatusTest::Combo::OR));
    all->addStatusTest(fv_test);
    all->addStatusTest(conv);
    all->addStatusTest(max_test);

    auto nl = Teuchos::parameterList("NOX");
    // Line search only: NOX 13.2's trust regions (Trust Region Based, Inexact Trust Region
    // Based) need J^T F before the first linear solve, and NOX::Thyra::Group applies J^T
    // through a linear-solve object that does not exist yet (an exception, or a segmentation
    // fault in Thyra::BelosLinearOpWithSolve::applyImpl, measured here).
    const auto glob = P.get<std::string>("Globalization");
    nl->set("Nonlinear Solver", "Line Search Based");
    auto& lsearch = nl->sublist("Line Search");
    lsearch.set("Method", glob == "Full step"                ? "Full Step"
                          : glob == "Polynomial line search" ? "Polynomial"
                                                             : "Backtrack");
    // A line search that finds no decrease ends the solve (NOX: 'Recovery Step' 0 makes the
    // step fail) instead of taking NOX's default recovery step, a full Newton step that can
    // raise ||F|| by orders of magnitude (measured on the N-DAM pressure system): the returned
    // iterate is then the best one found.
    for (const char* m : {"Backtrack", "Polynomial"}) lsearch.sublist(m).set("Recovery Step", 0.0);
    auto& dir = nl->sublist("Direction");
    dir.set("Method", "Newton");
    auto& newton = dir.sublist("Newton");
    const auto forcing = P.get<std::string>("Forcing term");
    const double ktol = P.get<double>("Krylov tolerance");
    newton.set("Forcing Term Method", forcing == "Constant"             ? "Constant"
                                      : forcing == "Eisenstat-Walker 1" ? "Type 1"
                                                                        : "Type 2");
    if (forcing != "Constant") {
      newton.set("Forcing Term Initial Tolerance", ktol);
      newton.set("Forcing Term Minimum Tolerance", std::min(ktol, 1e-10));
      newton.set("Forcing Term Maximum Tolerance", std::max(ktol, 0.1));
    }
    auto& ls = newton.sublist("Linear Solver");
    ls.set("Tolerance", ktol);
    ls.set("Max Iterations", P.get<int>("Max Krylov iterations"));
    auto& pr = nl->sublist("Printing");
    pr.set("Output Processor", 0);
    pr.set("MyPID", m.comm->getRank());
    int info = NOX::Utils::Error;
    if (P.get<bool>("Verbose"))
      info += NOX::Utils::Warning + NOX::Utils::OuterIteration +
              NOX::Utils::OuterIterationStatusTest + NOX::Utils::LinearSolverDetails;
    pr.set("Output Information", info);
    // NOX writes some messages (e.g. "line search failed") whatever the print level; without
    // 'Verbose' they go nowhere: the outcome is reported through NonlinearStats::reason.
    if (!P.get<bool>("Verbose"))
      pr.set("Output Stream", Teuchos::RCP<std::ostream>(rcp(new Teuchos::oblackholestream)));
    RCP<NOX::Observer> observer = rcp(new HistoryObserver(&st.residual_history));
    nl->sublist("Solver Options").set("Observer", observer);

    auto solver = NOX::Solver::buildSolver(group, all, nl);
    const auto status = solver->solve();

    const auto& sol = solver->getSolutionGroup();
    st.newton_iterations = solver->getNumIterations();
    st.final_residual = sol.getNormF();
    {
      const auto& sx = dynamic_cast<const NOX::Thyra::Vector&>(sol.getX());
      auto xt = TOE::getConstTpetraVector(sx.getThyraRCPVector());
      auto d = xt->getData();
      for (LO i = 0; i < m.nlocal; ++i) p[static_cast<size_t>(i)] = d[i];
    }
    // NOX::Thyra::Group accumulates Belos' iteration counts in the "Output" sublist of the
    // linear solver list (absent when no linear solve ran).
    const ParameterList* out = &solver->getList();
    for (const char* name : {"Direction", "Newton", "Linear Solver", "Output"})
      out = out && out->isSublist(name) ? &out->sublist(name) : nullptr;
    if (out && out->isParameter("Cumulative Iteration Count"))
      st.krylov_iterations = out->get<int>("Cumulative Iteration Count");

    const std::string norms = "||F|| = " + fmt(st.final_residual) + " (||F0|| = " +
                              fmt(st.initial_residual) + ", absolute tolerance " + fmt(atol) +
                              ", relative tolerance " + fmt(rtol) + ")";
    if (status == NOX::StatusTest::Converged) {
      st.converged = true;
      st.reason = "converged after " + std::to_string(st.newton_iterations) +
                  " Newton iterations: " + norms;
    } else if (fv_test->getStatus() == NOX::StatusTest::Failed ||
               !std::isfinite(st.final_residual)) {
      st.reason = "non-finite residual norm (NaN or Inf) after " +
                  std::to_string(st.newton_iterations) + " Newton iterations";
    } else if (max_test->getStatus() == NOX::StatusTest::Failed) {
      st.reason = "maximum Newton iterations (" + std::to_string(maxit) + ") reached: " + norms;
    } else {
      st.reason = "Newton step failed after " + std::to_string(st.newton_iterations) +
                  " iterations (the line search could not reduce ||F||; the Jacobian, the "
                  "preconditioner or the Krylov tolerance may be wrong): " +
                  norms;
    }
  } catch (const std::exception& e) {
    st.converged = false;
    st.reason = std::string("exception during the nonlinear solve: ") + e.what();
  }
  st.seconds = seconds_since(t0);
  return st;
}

RCP<const ParameterList> NonlinearSystem::getValidParameters() {
  using namespace params;
  auto pl = rcp(new ParameterList("Nonlinear solver"));
  add_enum(*pl, "Method", kAnalytic,
           "Newton-Krylov with the Jacobian assembled by the model (quadratic convergence), or "
           "Jacobian-free Newton-Krylov (J v by forward differences of F; the model's matrix "
           "only builds the preconditioner)",
           {kAnalytic, kJFNK});
  add_double(*pl, "Absolute tolerance", 1e-8,
             "converged when ||F||_2 <= this (or the relative test holds)", 0.0, 1e10);
  add_double(*pl, "Relative tolerance", 1e-8,
             "converged when ||F||_2 <= this * ||F(p0)||_2 (or the absolute test holds)", 0.0,
             1.0);
  add_int(*pl, "Max Newton iterations", 20,
          "Newton steps before the solve is reported not converged", 1, 10000);
  add_enum(*pl, "Globalization", "Backtracking line search",
           "NOX globalization: backtracking or polynomial line search on ||F||, or the full "
           "Newton step (NOX's trust regions do not work through NOX::Thyra::Group in "
           "Trilinos 13.2)",
           {"Backtracking line search", "Polynomial line search", "Full step"});
  add_enum(*pl, "Krylov solver", "GMRES",
           "Belos method for the Newton steps: GMRES (any Jacobian), CG (symmetric positive "
           "definite Jacobian only)",
           {"GMRES", "CG"});
  add_double(*pl, "Krylov tolerance", 1e-6,
             "relative linear residual of each Newton step (the initial one with "
             "Eisenstat-Walker forcing)",
             1e-14, 0.9);
  add_enum(*pl, "Forcing term", "Constant",
           "Krylov tolerance per Newton step: Constant, or Eisenstat-Walker choice 1 or 2 "
           "(loose far from the solution, tight near it)",
           {"Constant", "Eisenstat-Walker 1", "Eisenstat-Walker 2"});
  add_int(*pl, "Max Krylov iterations", 300, "Krylov iterations per Newton step", 1, 1000000);
  add_int(*pl, "GMRES restart", 40,
          "Krylov vectors kept between GMRES restarts (each costs a vector of the system; 40 "
          "covers the 5-25 iterations per Newton step measured with MueLu)",
          1, 10000);
  add_enum(*pl, "Preconditioner", "MueLu",
           "right preconditioner built from the model's matrix: MueLu smoothed-aggregation "
           "AMG (MueLu sublist), Ifpack2 RILUK or RELAXATION (Ifpack2 sublist), or None",
           {"MueLu", "Ifpack2 RILUK", "Ifpack2 RELAXATION", "None"});
  add_bool(*pl, "Reuse preconditioner", false,
           "false: rebuilt at every Newton step from the matrix at the current p; true: built "
           "once per solve at the initial guess (cheaper when the matrix hardly depends on p)");
  add_double(*pl, "FD lambda", 1e-4,
             "Jacobian-free only: relative perturbation of the finite-difference J v "
             "(1e-6 diverged on the nonlinear Poisson test, 1e-4 converged)",
             1e-12, 1e-1);
  add_bool(*pl, "Verbose", false, "NOX prints its iterations on rank 0");
  ParameterList ml = default_muelu();
  ml.disableRecursiveValidation();
  pl->set("MueLu", ml,
          "handed to MueLu::CreateTpetraPreconditioner as it is (MueLu's names); defaults: "
          "smoothed aggregation, one symmetric Gauss-Seidel sweep, relaxation coarse solve");
  ParameterList ip("Ifpack2");
  ip.disableRecursiveValidation();
  pl->set("Ifpack2", ip,
          "handed to the Ifpack2 preconditioner as it is (Ifpack2's names, for the chosen "
          "method only); RILUK defaults to 'fact: iluk level-of-fill' = 1, RELAXATION to one "
          "Jacobi sweep");
  return pl;
}

}  // namespace granflow::solvers
