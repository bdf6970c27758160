#pragma once
// The inclined channel: length, slope and what happens at its two ends. Shared by all models;
// each model turns a BoundarySpec into its own boundary condition.
#include <Teuchos_ParameterList.hpp>

#include <string>
#include <vector>

namespace granflow::core {

enum class BoundaryType { Inflow, Outflow, Wall, Periodic };
std::string to_string(BoundaryType t);

/// Prescribed inflow: constant (h, u) or a piecewise-linear time series read from a CSV file
/// with columns t,h,u (held constant beyond its last time).
class InflowSeries {
 public:
  InflowSeries() = default;
  InflowSeries(double h, double u);
  /// Reads "t,h,u" rows (a header line is allowed). Throws InputError naming the file and line.
  static InflowSeries from_csv(const std::string& file, const std::string& parameter_path);
  double depth(double t) const;
  double velocity(double t) const;
  /// The volume per unit width that enters in [t0, t1], the integral of h(t) u(t) [m^2]: exact
  /// for the piecewise-linear series (Simpson's rule between its rows, where h u is quadratic).
  double discharge(double t0, double t1) const;
  /// The series' rows strictly inside (t0, t1): h and u are linear between them.
  std::vector<double> rows_between(double t0, double t1) const;
  bool is_constant() const { return t_.size() <= 1; }
  std::size_t rows() const { return t_.size(); }  ///< the series' rows (1: constant)
  /// The file the series was read from, resolved against the scene's directory as the other
  /// series messages name it (empty: constant).
  const std::string& file() const { return file_; }
  /// The deepest opening of the series (its largest h row).
  double max_depth() const;
  /// The fastest inflow of the series (its largest |u| row; linear between rows).
  double max_speed() const;

 private:
  double interp(const std::vector<double>& v, double t) const;
  std::vector<double> t_{0.0}, h_{0.0}, u_{0.0};
  std::string file_;
};

/// An input file named in a scene: absolute as given, else relative to the scene's directory.
std::string input_path(const std::string& file, const std::string& scene_dir);

struct BoundarySpec {
  BoundaryType type = BoundaryType::Outflow;
  InflowSeries inflow;  ///< used only when type == Inflow
};

/// The defaults are the paper's Setup II chute (1 m at 50 deg, fed through a silo gate of
/// 6 cm at 0.37 m/s, open downstream end); getValidParameters() takes its defaults from here.
struct Channel {
  double length = 1.0;      ///< L [m]
  double slope_deg = 50.0;  ///< zeta [deg]
  BoundarySpec left{BoundaryType::Inflow, InflowSeries(0.06, 0.37)};
  BoundarySpec right{BoundaryType::Outflow, InflowSeries()};

  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters();
  /// Reads a validated "Channel" list. `user` is the list as the user wrote it (before defaults
  /// were filled in) so that inconsistent combinations, such as inflow data on a closed end,
  /// are caught; `scene_dir` resolves relative file names.
  static Channel from_parameters(const Teuchos::ParameterList& validated,
                                 const Teuchos::ParameterList& user, const std::string& scene_dir);
  double g_sin(double g) const;  ///< downslope gravity g sin zeta
  double g_cos(double g) const;  ///< bed-normal gravity g cos zeta
};

}  // namespace granflow::core
