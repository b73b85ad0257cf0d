// Two-sample statistics for the specificity study (docs/estimation.md s.7): effect sizes, Welch's t
// test (also with each subject's posterior variance carried in), the Mann-Whitney U test and the
// AUC, multiple-comparison adjustment (Holm, Benjamini-Hochberg), and the special functions they
// need.
#pragma once

#include <Eigen/Core>

#include <string>

namespace sigmaheart::estimation::specificity {

// Regularised incomplete beta I_x(a, b), a, b > 0, x in [0, 1]: the continued fraction of
// Numerical Recipes (Press et al. 2007, 3rd ed., s.6.4, eq. 6.4.5) evaluated by the modified Lentz
// method (Lentz 1976; Thompson & Barnett 1986), with the symmetry I_x(a,b) = 1 - I_{1-x}(b,a) used
// where x > (a + 1)/(a + b + 2) so the fraction converges quickly.
double regularized_incomplete_beta(double a, double b, double x);

// Student-t cumulative distribution with df > 0 degrees of freedom (df need not be an integer):
// P(T <= t) = 1 - I_{df/(df+t^2)}(df/2, 1/2) / 2 for t >= 0 (Abramowitz & Stegun 26.7.1).
double student_t_cdf(double t, double df);
// Standard normal cumulative distribution, via erfc.
double normal_cdf(double z);

struct GroupSummary {
  int n = 0;
  double mean = 0.0;
  double sd = 0.0;  // sample standard deviation (divisor n - 1)
};
GroupSummary summarise(const Eigen::Ref<const Eigen::VectorXd>& x);

struct EffectSize {
  // Cohen's d = (mean_x - mean_y) / s_pooled, s_pooled^2 = ((n_x-1) s_x^2 + (n_y-1) s_y^2)/(n_x+n_y-2)
  // (Cohen 1988, eq. 2.5.2).
  double cohen_d = 0.0;
  // Hedges' g = J d with the small-sample correction J = 1 - 3 / (4 (n_x + n_y) - 9) (Hedges 1981).
  double hedges_g = 0.0;
};
EffectSize effect_size(const Eigen::Ref<const Eigen::VectorXd>& x,
                       const Eigen::Ref<const Eigen::VectorXd>& y);

// Welch's unequal-variance t test (Welch 1947, Biometrika 34:28): t = (mean_x - mean_y) / se,
// se^2 = s_x^2/n_x + s_y^2/n_y, Welch-Satterthwaite df = se^4 / ((s_x^2/n_x)^2/(n_x-1) +
// (s_y^2/n_y)^2/(n_y-1)); two-sided p = 2 P(T_df > |t|). Needs n >= 2 in each group; when both
// variances are zero, t = +-inf (p = 0) for different means and NaN for equal means.
struct WelchResult {
  double t = 0.0;
  double df = 0.0;
  double p_value = 1.0;
  double mean_difference = 0.0;  // mean_x - mean_y
};
WelchResult welch_t_test(const Eigen::Ref<const Eigen::VectorXd>& x,
                         const Eigen::Ref<const Eigen::VectorXd>& y);

// Mann-Whitney U test (Mann & Whitney 1947, Ann Math Stat 18:50). U counts the pairs (x_i, y_j)
// with x_i > y_j, ties counting 1/2, so U / (n_x n_y) is the AUC = P(X > Y) + P(X = Y)/2 (Bamber
// 1975). p-value, two-sided:
//  - exact: when there are no ties and n_x + n_y <= 40, from the permutation distribution of U
//    (the recursion of Mann & Whitney 1947, eq. 2), p = min(1, 2 min(P(U <= u), P(U >= u)));
//  - otherwise the normal approximation with tie-corrected variance
//    var U = n_x n_y / 12 ((n + 1) - sum_k (t_k^3 - t_k) / (n (n - 1))), n = n_x + n_y, t_k the tie
//    group sizes (Lehmann 1975, eq. 1.65), and a continuity correction of 1/2.
// AUC standard error of Hanley & McNeil (1982, Radiology 143:29, eq. 1), Q1 = A/(2-A),
// Q2 = 2A^2/(1+A).
struct MannWhitneyResult {
  double U = 0.0;  // for x over y
  double z = 0.0;  // normal score (continuity-corrected); 0 when exact
  double p_value = 1.0;
  bool exact = false;
  double auc = 0.5;
  double auc_se = 0.0;
};
MannWhitneyResult mann_whitney(const Eigen::Ref<const Eigen::VectorXd>& x,
                               const Eigen::Ref<const Eigen::VectorXd>& y);

// Welch's test on per-subject estimates that carry their own posterior variance (docs/estimation.md
// s.7). Each subject i of a group is x_i = mu + b_i + e_i with a between-subject deviation b_i of
// variance tau^2 and an estimation error e_i of variance s_i^2 (its posterior variance), so
// var x_i = tau^2 + s_i^2 (the random-effects model of DerSimonian & Laird 1986, Control Clin Trials
// 7:177, eq. 2). The group mean is the inverse-variance weighted mean with w_i = 1 / (tau^2 + s_i^2),
// its variance V = 1 / sum w_i (ibid., eqs. 3-4); t = (m_x - m_y) / sqrt(V_x + V_y) with the
// Welch-Satterthwaite df = (V_x + V_y)^2 / (V_x^2 / (n_x - 1) + V_y^2 / (n_y - 1)).
// tau^2 is the sample variance of the x_i themselves, NOT reduced by the mean s_i^2 as DerSimonian
// and Laird do: the scatter of posterior means need not contain the posterior spread (a calibration
// shrinks towards its prior), so the posterior variance is added on top. With every s_i = 0 this is
// exactly welch_t_test; large s_i make a difference non-significant. NaN s_i count as 0.
WelchResult posterior_welch_test(const Eigen::Ref<const Eigen::VectorXd>& x,
                                 const Eigen::Ref<const Eigen::VectorXd>& sd_x,
                                 const Eigen::Ref<const Eigen::VectorXd>& y,
                                 const Eigen::Ref<const Eigen::VectorXd>& sd_y);

// Multiple-comparison adjustment of m p-values (one per parameter): an adjusted p-value is the
// smallest family level at which the hypothesis would be rejected. NaN entries stay NaN and do not
// count in m.
//  - Holm 1979 (Scand J Stat 6:65), step-down, controls the family-wise error rate:
//    p~_(i) = max_{j <= i} min(1, (m - j + 1) p_(j)), p_(1) <= ... <= p_(m).
//  - Benjamini & Hochberg 1995 (J R Stat Soc B 57:289), step-up, controls the false discovery rate
//    for independent (or positively dependent) tests: p~_(i) = min_{j >= i} min(1, m p_(j) / j).
enum class PAdjust { kHolm, kBenjaminiHochberg };
const char* to_string(PAdjust method);
Eigen::VectorXd adjust_p_values(const Eigen::Ref<const Eigen::VectorXd>& p, PAdjust method);

// Which way group B lies from group A, from AUC = P(B > A) + P(B = A)/2: "higher" (AUC > 0.5),
// "lower" (AUC < 0.5) or "none" (AUC = 0.5).
std::string auc_direction(double auc);

}  // namespace sigmaheart::estimation::specificity
