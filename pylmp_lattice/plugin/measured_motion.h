/* A measured impactor motion u(t) or v(t): not-a-knot cubic spline of the samples.
   Shared by fix lattice/piston and fix lattice/chain. Part of pylmp_lattice, GPL-2.0. */

#ifndef PYLMP_LATTICE_MEASURED_MOTION_H
#define PYLMP_LATTICE_MEASURED_MOTION_H

#include <string>
#include <vector>

namespace LAMMPS_NS {

class Error;

class MeasuredMotion {
 public:
  /* read `path` (two columns t, value; blanks or commas; '#' comments; >= 4 samples,
     t strictly increasing) and fit the spline; errors go through `error` with `who` */
  void load(const std::string &path, bool given_velocity, bool hold_after, Error *error,
            const char *who);
  /* displacement u from the first sample and velocity ud at time tau after t[0]; past the
     data: held at the last position (hold) or an error (stop) beyond a round-off `slack` */
  void at(double tau, double slack, double &u, double &ud) const;

 private:
  std::string path, who;
  bool given_velocity = false;    // the file's column is v (else u)
  bool hold_after = false;
  Error *error = nullptr;
  // knots t, values y, second derivatives d2y; yint = integral of the spline from t[0]
  std::vector<double> t, y, d2y, yint;

  void read_file();
  void fit_spline();
};

}    // namespace LAMMPS_NS

#endif
