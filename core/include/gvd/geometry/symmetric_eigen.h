#pragma once

// Eigenvectors of a symmetric 3 x 3 matrix by cyclic Jacobi rotations (Golub & Van Loan
// §8.5): the junction points' least-change step (surface/cell_surfacer.cpp) and the planes
// fitted to float32 faces (scene/snap_faces.cpp).

#include <cmath>

namespace gvd {

/// Diagonalises the symmetric matrix `a` in place by Jacobi rotations: on return its diagonal
/// holds the eigenvalues and the columns of `v` the unit eigenvectors (v starts as the
/// identity). Stops after 32 sweeps or when the squared off-diagonal entries add up to at
/// most 1e-30 of the squared diagonal.
inline void symmetric_eigen(double a[3][3], double v[3][3]) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) v[i][j] = i == j ? 1 : 0;
  for (int sweep = 0; sweep < 32; ++sweep) {
    const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    const double diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
    if (!(off > 1e-30 * diag)) break;
    for (int pi = 0; pi < 2; ++pi) {
      for (int qi = pi + 1; qi < 3; ++qi) {
        if (a[pi][qi] == 0) continue;
        const double theta = (a[qi][qi] - a[pi][pi]) / (2 * a[pi][qi]);
        const double t =
            (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1));
        const double c = 1 / std::sqrt(t * t + 1), sn = t * c;
        for (int k = 0; k < 3; ++k) {  // a <- a J (columns pi, qi)
          const double akp = a[k][pi], akq = a[k][qi];
          a[k][pi] = c * akp - sn * akq;
          a[k][qi] = sn * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {  // a <- J^T a (rows pi, qi)
          const double apk = a[pi][k], aqk = a[qi][k];
          a[pi][k] = c * apk - sn * aqk;
          a[qi][k] = sn * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {  // v <- v J
          const double vkp = v[k][pi], vkq = v[k][qi];
          v[k][pi] = c * vkp - sn * vkq;
          v[k][qi] = sn * vkp + c * vkq;
        }
      }
    }
  }
}

}  // namespace gvd
