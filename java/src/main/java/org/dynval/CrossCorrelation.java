package org.dynval;

/**
 * Cross-correlation of each joint's residual with that joint's regressor columns (contract §3.6):
 * {@code rho[j][c][lag]}, {@code constantMask[j][c]} (a constant column gives a row of nan),
 * and the white band z/√N at {@code level}.
 */
public record CrossCorrelation(double[][][] rho, boolean[][] constantMask, double band, double level) {
}
