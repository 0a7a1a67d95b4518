package org.dynval;

import java.util.ArrayList;
import java.util.List;

/**
 * Segments: independent records concatenated along the sample axis (contract §1.1), carried as
 * starts whose first element is 0. Lagged products never join two segments.
 */
final class Segments {
    private Segments() {
    }

    static final int[] ONE = {0};

    /** Parse {@code null}, lengths or starts into starts for N = {@code n} samples. */
    static int[] parse(Object segments, int n) {
        if (segments == null) {
            return ONE.clone();
        }
        InputError error = Checks.parameterError("segments",
                "positive lengths summing to N=" + n + ", or increasing starts beginning at 0 and below N=" + n, segments);
        List<Long> values = new ArrayList<>();
        if (segments instanceof List) {
            for (Object v : (List<?>) segments) {
                if (!Checks.isInteger(v)) {
                    throw error;
                }
                values.add(Checks.asLong(v));
            }
        } else if (segments instanceof int[]) {
            for (int v : (int[]) segments) {
                values.add((long) v);
            }
        } else {
            throw error;
        }
        if (values.isEmpty()) {
            throw error;
        }
        int[] starts = new int[values.size()];
        if (values.get(0) == 0) {
            for (int i = 1; i < values.size(); i++) {
                if (values.get(i) <= values.get(i - 1)) {
                    throw error;
                }
            }
            if (values.get(values.size() - 1) >= n) {
                throw error;
            }
            for (int i = 0; i < starts.length; i++) {
                starts[i] = (int) (long) values.get(i);
            }
            return starts;
        }
        long total = 0;
        for (long v : values) {
            if (v <= 0) {
                throw error;
            }
            total += v;
            if (total > n) {
                throw error; // also keeps the running sum far from overflow
            }
        }
        if (total != n) {
            throw error;
        }
        long at = 0;
        for (int i = 0; i < starts.length; i++) {
            starts[i] = (int) at;
            at += values.get(i);
        }
        return starts;
    }

    static int[] lengths(int[] starts, int n) {
        int[] out = new int[starts.length];
        for (int s = 0; s < starts.length; s++) {
            int end = s + 1 < starts.length ? starts[s + 1] : n;
            out[s] = end - starts[s];
        }
        return out;
    }

    /** Length of the longest segment: the bound on lags. */
    static int longest(int[] starts, int n) {
        int best = 0;
        for (int len : lengths(starts, n)) {
            best = Math.max(best, len);
        }
        return best;
    }

    /** n_ℓ = Σ_s max(n_s − ℓ, 0): the number of lag-ℓ products. */
    static long productCount(int[] starts, int n, int lag) {
        long total = 0;
        for (int len : lengths(starts, n)) {
            total += Math.max(len - lag, 0);
        }
        return total;
    }

    /**
     * New starts after deleting rows ({@code keep[i]} false): the caller's segments refined, a
     * kept row opening a segment wherever the row before it was deleted.
     */
    static int[] refine(int[] starts, boolean[] keep) {
        int n = keep.length;
        boolean[] isStart = new boolean[n];
        for (int s : starts) {
            isStart[s] = true;
        }
        List<Integer> out = new ArrayList<>();
        int kept = 0;
        for (int i = 0; i < n; i++) {
            if (!keep[i]) {
                continue;
            }
            boolean previousDeleted = i == 0 || !keep[i - 1];
            if (isStart[i] || previousDeleted) {
                out.add(kept);
            }
            kept++;
        }
        if (out.isEmpty()) {
            return ONE.clone();
        }
        int[] result = new int[out.size()];
        for (int i = 0; i < result.length; i++) {
            result[i] = out.get(i);
        }
        return result;
    }
}
