#pragma once
// Reading and comparing runs through their profiles.csv (the output contract's depth-averaged
// profiles, identical in form for 1D, 2D and coupled runs):
//
//  * the paper's relative error r = |v_test - v_ref| / |v_ref| of h and u_mean at given times,
//    as its maximum and as the L2 ratio sqrt(sum (v_test - v_ref)^2 / sum v_ref^2) over the
//    flowing part of the channel (where the reference depth exceeds a threshold);
//  * the velocity averaged over [0, l], u(l) = 1/l int_0^l u_mean dx, against time (Fig. 14);
//  * the shallowness parameter eps along the channel, from which an a priori 2D/1D layout is
//    proposed (paper section 4.1: 2D wherever eps >= threshold, plus a margin).
#include <map>
#include <string>
#include <vector>

namespace granflow::analysis {

struct ProfileAt {
  std::vector<double> x, h, u, eps;
  std::vector<std::string> model;
};

/// All output times of one run: t -> profile. Throws std::runtime_error naming file and line.
/// The outputs of a run's profiles.csv. An output that the file holds only in part (a run still
/// writing it, or stopped inside it: the last line without its newline, or the last output
/// ending before the channel's end that the output before it reached) is left out, and `note`
/// (when given) says so; empty otherwise.
std::map<double, ProfileAt> read_profiles(const std::string& csv_file, std::string* note = nullptr);

struct ErrorNorms {
  double max_rel = 0.0;  ///< max over flowing points of |v_t - v_r| / |v_r|
  double l2_rel = 0.0;   ///< sqrt(sum (v_t - v_r)^2 / sum v_r^2) over flowing points
  int points = 0;        ///< flowing points compared
};

struct ProfileErrors {
  ErrorNorms h, u;
};

/// Errors of `test` against `ref` at one time. `test` is linearly interpolated onto the x of
/// `ref`; points count as flowing where h_ref > h_min and |u_ref| > u_min (so the relative
/// error of u is defined).
ProfileErrors compare(const ProfileAt& ref, const ProfileAt& test, double h_min, double u_min);

/// u(l) = 1/l int_0^l u_mean dx by the midpoint rule over the cells with x < l (dry cells
/// contribute u_mean = 0).
double average_velocity(const ProfileAt& p, double l);

struct Subdomain {
  std::string model;  ///< "2D" or "1D"
  double x0, x1;
};

/// The default criteria of the a priori layout below, shared by the scene's Decomposition
/// ('Shallowness threshold', 'Margin', 'Minimum length') and granflow-study's layout command.
struct LayoutCriteria {
  /// 2D where eps >= this: the paper's minimum requirement at an interface is eps < 0.1.
  double threshold = 0.1;
  /// [m] widening of each 2D region (the paper: "somewhat greater than suggested by the
  /// one-dimensional simulation").
  double margin = 0.05;
  double min_length = 0.05;  ///< [m] shorter 1D gaps and end pieces become 2D
};

/// A cell counts as wet for the layout (its eps is used) where h exceeds this many times the
/// DAM's dry depth: a film within a decade of the dry depth is the numerically wetted tip of a
/// front, where u is set from a vanishing depth and eps = beta h / u^2 is not a flow property.
constexpr double kLayoutWetDepthFactor = 10.0;
/// The wet-depth cut of the a priori layout for a DAM run with dry depth `dry_depth` [m].
inline double layout_wet_depth(double dry_depth) { return kLayoutWetDepthFactor * dry_depth; }

/// A priori layout (paper section 4.1): 2D wherever max over time of eps >= threshold (wet
/// cells, h > h_min, only), each such region widened by `margin` on both sides, merged, clipped
/// to [0, length]; 1D elsewhere. Subdomains shorter than `min_length` are absorbed into 2D.
std::vector<Subdomain> propose_layout(const std::map<double, ProfileAt>& run, double length,
                                      double threshold, double margin, double min_length,
                                      double h_min);

}  // namespace granflow::analysis
