(* ::Package:: *)

(* DynVal streaming: a mergeable accumulator of the validation metrics (docs/contract.md 4.1) and
   the protocol operation accumulate (golden/PROTOCOL.md 11, family streaming). Loaded by DynVal.wl.

   The state does not grow with the number of rows: per joint, centred sums of the target and of
   the residual's lagged products (lags 0..L, L = max_lag) with the sums of their current and
   lagged elements; the same for each regressor column against its joint's residual; the m x m
   residual products for the "full" noise model; minima and maxima; the number of segments and
   the lengths of the first, last and longest; and the first and last L rows (raw), from which a
   merge forms the lagged products that cross the junction. Every sum is centred on the running
   mean (moved by Chan's pairwise update, extended to lagged products, at each merge), so a large
   offset costs no digits, and carried as a compensated pair comp[hi, lo] (TwoSum), so that many
   small chunks sum as accurately as one block.

   Rows arrive joint-major: a signal is m lists of c values (the regressor m p lists, column
   j p + k for joint j, column k). The compensated sums of a state are one flat vector (layout
   below), so that a merge is a few whole-vector steps: Mathics3 spends its time per step and per
   element. A block's sums cost (L + 1) c m products, as whole-list Times and Total per lag and
   column; a merge costs O(L m p + m^2 + L^2 m p), independent of the rows. *)

BeginPackage["DynVal`"];

validationAccumulator::usage = "validationAccumulator[nParams, maxLag, \"noise_model\" -> \"pooled\"] gives an empty accumulator of the validation metrics (contract 4.1).";
accumulatorUpdate::usage = "accumulatorUpdate[acc, tauMeas, tauPred] or accumulatorUpdate[acc, tauMeas, tauPred, regressor] gives acc with the next rows, (c,) or (c, m) torques and a (c, m, p) regressor.";
accumulatorBreak::usage = "accumulatorBreak[acc] ends the current segment: no lagged product joins the rows before and after.";
accumulatorMerge::usage = "accumulatorMerge[acc, later] gives the accumulator of acc's rows followed by later's (lags join across the junction unless a segment break lies there).";
accumulatorResult::usage = "accumulatorResult[acc] gives the metrics of every row so far: sse, rmse, max_abs_error, vaf, fit_percent, r2, residual_mean, residual_variance, autocorrelation, rho (with a regressor) and the criteria under the noise model.";
accumulatorSamples::usage = "accumulatorSamples[acc] gives the number of rows so far.";
streamAccumulate::usage = "streamAccumulate[tauMeas, tauPred, regressor, nParams, maxLag, \"chunks\" -> {...}, \"merge\" -> \"none\"|\"left\"|\"right\"|\"tree\", \"segments\" -> ..., \"noise_model\" -> ..., \"nan_policy\" -> \"raise\"] feeds an accumulator the rows in the given blocks (regressor None when there is none) and gives accumulatorResult: the protocol operation accumulate.";
ValidationAccumulator::usage = "ValidationAccumulator[state] is an accumulator (validationAccumulator).";

Begin["`Private`"];

(* ------------------------------------------------------------------ compensated sums *)

(* comp[hi, lo]: hi + lo, lo holding what each addition rounded away (TwoSum, elementwise). *)
compAdd[comp[hi_, lo_], comp[xh_, xl_]] := With[{s = hi + xh}, With[{b = s - hi},
  comp[s, lo + ((hi - (s - b)) + (xh - b)) + xl]]];
compAdd[comp[hi_, lo_], x_] := With[{s = hi + x}, With[{b = s - hi},
  comp[s, lo + ((hi - (s - b)) + (x - b))]]];
val[comp[hi_, lo_]] := hi + lo;

(* s[key] = value for an Association held by the variable s (Mathics3 does not assign to a key). *)
SetAttributes[put, HoldFirst];
put[s_, key_, value_] := (s = Append[s, key -> value]);

(* x 2^k with k a list (one exponent per entry, or per row of a matrix x), exactly unless the
   result is subnormal: factors of at most 2^1000 each (pow2 of DynVal.wl, for lists). *)
pow2List[x_, k_List] := If[Max[Abs[k]] <= 1000, x 2.^k,
  With[{step = (Max[-1000, Min[1000, #]] &) /@ k}, pow2List[x 2.^step, k - step]]];
shifted[x_, k_List] := If[Max[Abs[k]] == 0, x, pow2List[x, k]];

(* The power-of-two exponent of each row of x (joint or column; contract 4.1, Scale): every centre
   and sum of a state is held in units 2^k of its column, k that of the largest |x| seen, so no
   square or product underflows or overflows; extremes and boundary rows stay raw. *)
rowExponents[ends_List] := (If[# == 0, 0, Floor[Log[2., #]] + 1] &) /@ (Max[Abs[#]] & /@ ends);

(* a (length k) and b (length l): the k x l matrix a_i b_j *)
outer[a_List, b_List] := Outer[Times, a, b];

(* The joint of each regressor column, 1-based. *)
jointIndex[m_, p_] := jointIndex[m, p] = Flatten[Table[ConstantArray[j, p], {j, m}]];

(* A column of L + 1 sums, lag l computed by f for l <= top and 0 beyond. *)
lagColumn[f_, top_, lags_] := PadRight[Table[f[l], {l, 0, top}], lags + 1, 0.];

(* Every compensated sum of a state lives in one flat vector, so that a merge moves and adds them
   in a few whole-vector steps (Mathics3 spends its time per step and per element, not per value
   of a Total). The parts, in this order, joint-major with L + 1 lags per row where lagged:
   prod_e, cur_e, lag_e (m x (L+1)): Sum (e_t - K)(e_(t-l) - K), Sum (e_t - K), Sum (e_(t-l) - K)
     over the pairs of lag l;
   products (m x m, "full" noise model only): Sum (e_i - K_i)(e_j - K_j);
   sum_t, sq_t (m): Sum (t - K_t), Sum (t - K_t)^2;
   sq_y (m p), lag_y, prod_ey (m p x (L+1)), with a regressor only: Sum (Y - K_Y)^2,
     Sum (Y_(t-l) - K_Y), Sum (e_t - K)(Y_(t-l) - K_Y) with e of the column's joint. *)
$sumNames = {"prod_e", "cur_e", "lag_e", "products", "sum_t", "sq_t", "sq_y", "lag_y", "prod_ey"};
layout[m_, p_, lags_, gram_] := layout[m, p, lags, gram] = With[
  {sizes = {m (lags + 1), m (lags + 1), m (lags + 1), If[gram, m m, 0], m, m, m p, m p (lags + 1), m p (lags + 1)}},
  Association @@ MapThread[#1 -> {#3 - #2 + 1, #3} &, {$sumNames, sizes, accumulate[sizes]}]];

(* The flat vector of the parts (matrices or vectors, {} for an absent part), in layout order. *)
flatSums[parts_List] := Join @@ (Flatten /@ parts);

(* One part of the flat values v of the state s: a vector, or a matrix of rows of L + 1 (or m) values. *)
(* Arguments that hold lists or associations are bound to local variables first: Mathics3 puts an
   argument into every place of the body where its pattern variable appears and evaluates each copy
   again, which for a state costs milliseconds per place (and per iteration of a loop). *)
sumsPart[sIn_, vIn_, name_] := Module[{s = sIn, v = vIn, span},
  span = layout[s["m"], s["p"], s["lags"], s["gram"]][name]; v[[span[[1]] ;; span[[2]]]]];
lagMatrix[sIn_, vIn_, name_] := Module[{s = sIn}, Partition[sumsPart[s, vIn, name], s["lags"] + 1]];

(* ------------------------------------------------------------------ one block *)

(* The sums of one record of c >= 1 consecutive rows: e, t (m x c) and y (m p x c, {} without a
   regressor), centred on the block's means. The block's lagged products are whole-list Times
   and Total per lag and column: (L + 1) c m products. *)
streamBlock[p_, lags_, gram_, eIn_, tIn_, yIn_] := Module[
  {e = eIn, t = tIn, y = yIn, m, c, top, ke, xe, kt, xt, ky = {}, xy, joint, kept, endsE, endsT, endsY = {}, hi,
   expE, expT, expY = {}},
  m = Length[e]; c = Length[First[e]];
  top = Min[lags, c - 1];
  kept = Min[lags, c];
  endsE = extremes /@ e; endsT = extremes /@ t;
  expE = rowExponents[endsE]; expT = rowExponents[endsT];
  xe = shifted[e, -expE]; ke = (Total /@ xe)/c; xe = xe - ke;
  xt = shifted[t, -expT]; kt = (Total /@ xt)/c; xt = xt - kt;
  If[p > 0,
    joint = jointIndex[m, p];
    endsY = extremes /@ y; expY = rowExponents[endsY];
    xy = shifted[y, -expY]; ky = (Total /@ xy)/c; xy = xy - ky];
  hi = flatSums[{
    Function[x, lagColumn[Total[x[[# + 1 ;; c]] x[[1 ;; c - #]]] &, top, lags]] /@ xe,
    Function[x, lagColumn[Total[x[[# + 1 ;; c]]] &, top, lags]] /@ xe,
    Function[x, lagColumn[Total[x[[1 ;; c - #]]] &, top, lags]] /@ xe,
    If[gram, Table[Total[xe[[i]] xe[[j]]], {i, m}, {j, m}], {}],
    Total /@ xt, Total /@ (xt xt),
    If[p > 0, Total /@ (xy xy), {}],
    If[p > 0, Function[x, lagColumn[Total[x[[1 ;; c - #]]] &, top, lags]] /@ xy, {}],
    If[p > 0, MapThread[Function[{x, z}, lagColumn[Total[x[[# + 1 ;; c]] z[[1 ;; c - #]]] &, top, lags]],
      {xe[[joint]], xy}], {}]}];
  <|"m" -> m, "p" -> p, "lags" -> lags, "gram" -> gram, "n" -> c, "start_break" -> False, "end_break" -> False,
    "segments" -> 1, "first_length" -> c, "last_length" -> c, "longest" -> c,
    "k_e" -> ke, "k_t" -> kt, "k_y" -> ky, "exp_e" -> expE, "exp_t" -> expT, "exp_y" -> expY,
    "sums" -> comp[hi, 0. hi], "pairs" -> Table[Max[c - l, 0], {l, 0, lags}],
    "min_e" -> endsE[[All, 1]], "max_e" -> endsE[[All, 2]], "min_t" -> endsT[[All, 1]], "max_t" -> endsT[[All, 2]],
    "min_y" -> If[p > 0, endsY[[All, 1]], {}], "max_y" -> If[p > 0, endsY[[All, 2]], {}],
    (* the raw rows a later merge needs for the products across the junction *)
    "head_e" -> (Take[#, kept] &) /@ e, "tail_e" -> (Take[#, -kept] &) /@ e,
    "tail_y" -> If[p > 0, (Take[#, -kept] &) /@ y, {}]|>];

(* ------------------------------------------------------------------ merging two states *)

(* Index vectors of a layout, remembered per shape: for the flat m (L+1) lagged parts the joint
   and the lag of each entry, for the m p (L+1) regressor parts the column, the lag and the entry of
   the column's joint in cur_e; the entries of lag 0. *)
lagIndex[m_, p_, lags_] := lagIndex[m, p, lags] = With[{k = lags + 1},
  <|"joint" -> Flatten[Table[ConstantArray[j, k], {j, m}]], "lag" -> Flatten[ConstantArray[Range[k], m]],
    "lag0" -> Range[1, m k, k],
    "column" -> Flatten[Table[ConstantArray[j, k], {j, m p}]], "lagY" -> Flatten[ConstantArray[Range[k], m p]],
    "curOfY" -> Flatten[Table[(jointIndex[m, p][[j]] - 1) k + Range[k], {j, m p}]], "lag0Y" -> Range[1, m p k, k]|>];

(* The flat values of the parts of a state, from one evaluation of hi + lo. *)
spanOf[s_, name_] := layout[s["m"], s["p"], s["lags"], s["gram"]][name];
piece[v_, {a_, b_}] := v[[a ;; b]];

meansOf[sIn_] := Module[{s = sIn, v, n, ix},
  v = val[s["sums"]]; n = s["n"]; ix = lagIndex[s["m"], s["p"], s["lags"]];
  {s["k_e"] + piece[v, spanOf[s, "cur_e"]][[ix["lag0"]]]/n, s["k_t"] + piece[v, spanOf[s, "sum_t"]]/n,
   If[s["p"] > 0, s["k_y"] + piece[v, spanOf[s, "lag_y"]][[ix["lag0Y"]]]/n, {}]}];

(* What moves every sum of s to new centres: x - K' = (x - K) - d, so Sum (x_t - K')(y_(t-l) - K'')
   = P - d_y H - d_x T + n_l d_x d_y, every correction taken from the sums before any of them moves.
   Flat vectors throughout: d and n_l are spread over the entries by index vectors. *)
recentreDelta[sIn_, ke_, kt_, ky_] := Module[{s = sIn, v, n, nl, ix, d, dR, dn, cur, lag, c0, dy, dyR, djR, dyn, ly, dt, st},
  v = val[s["sums"]];
  n = s["n"]; nl = s["pairs"]; ix = lagIndex[s["m"], s["p"], s["lags"]];
  d = ke - s["k_e"]; dt = kt - s["k_t"];
  dR = d[[ix["joint"]]]; dn = dR nl[[ix["lag"]]];
  cur = piece[v, spanOf[s, "cur_e"]]; lag = piece[v, spanOf[s, "lag_e"]];
  st = piece[v, spanOf[s, "sum_t"]];
  If[s["p"] > 0,
    dy = ky - s["k_y"]; dyR = dy[[ix["column"]]]; djR = d[[jointIndex[s["m"], s["p"]]]][[ix["column"]]];
    dyn = dyR nl[[ix["lagY"]]];
    ly = piece[v, spanOf[s, "lag_y"]]];
  c0 = cur[[ix["lag0"]]];
  Join[
      dR (dn - cur - lag), -dn, -dn,
      If[s["gram"], Flatten[-(outer[d, c0] + outer[c0, d]) + n outer[d, d]], {}],
      -n dt, dt (n dt - 2. st),
      If[s["p"] > 0, dy (n dy - 2. ly[[ix["lag0Y"]]]), {}],
      If[s["p"] > 0, -dyn, {}],
      If[s["p"] > 0, djR (dyn - ly) - dyR cur[[ix["curOfY"]]], {}]]];

(* s with every centre and sum moved to the exponents given (each at least s's own): a sum of
   products of columns a and b times 2^-(da + db), a sum or centre times 2^-da; exact. *)
rescaleState[sIn_, ee_, et_, ey_] := Module[{s = sIn, m, p, ix, de, dt, dy, dR, dyR, shifts},
  {m, p} = {s["m"], s["p"]};
  de = ee - s["exp_e"]; dt = et - s["exp_t"]; dy = If[p > 0, ey - s["exp_y"], {}];
  If[Max[Abs[Join[de, dt, dy]]] == 0, s,
    ix = lagIndex[m, p, s["lags"]];
    dR = de[[ix["joint"]]];
    If[p > 0, dyR = dy[[ix["column"]]]];
    shifts = -Join[2 dR, dR, dR, If[s["gram"], Flatten[Table[de[[i]] + de[[j]], {i, m}, {j, m}]], {}], dt, 2 dt,
      If[p > 0, 2 dy, {}], If[p > 0, dyR, {}], If[p > 0, de[[jointIndex[m, p]]][[ix["column"]]] + dyR, {}]];
    Join[s, <|"sums" -> comp[shifted[s["sums"][[1]], shifts], shifted[s["sums"][[2]], shifts]],
      "k_e" -> shifted[s["k_e"], -de], "k_t" -> shifted[s["k_t"], -dt],
      "k_y" -> If[p > 0, shifted[s["k_y"], -dy], {}], "exp_e" -> ee, "exp_t" -> et, "exp_y" -> ey|>]]];

(* The pairs across a junction of a's last tailRows rows and b's first headRows rows, remembered
   per shape: lag l pairs b's head row i (0-based, i < l) with a's tail row tailRows - l + i. Gives
   the head and tail columns of every pair (1-based), and per lag 0..L the first pair and the count. *)
junctionIndex[tailRows_, headRows_, lags_] := junctionIndex[tailRows, headRows, lags] = Module[
  {heads = {}, tails = {}, groups = {{1, 0}}, i},
  Do[
    i = Range[Max[0, l - tailRows], Min[l, headRows] - 1];
    groups = Append[groups, {Length[heads] + 1, Length[i]}];
    heads = Join[heads, i + 1]; tails = Join[tails, tailRows - l + i + 1],
    {l, 1, lags}];
  {heads, tails, groups}];

(* Per row of x (joint or column), the sums over the pairs of each lag: rows of L + 1 values (one
   Total over the rows per lag). *)
groupSums[x_, groups_] := transpose[Table[If[g[[2]] == 0, ConstantArray[0., Length[x]],
  Total /@ x[[All, g[[1]] ;; g[[1]] + g[[2]] - 1]]], {g, groups}]];

(* The lagged products across the junction, of rows centred on the common K of both states (in a's
   k_e, k_y): {the flat sums, the pair counts per lag}. *)
junctionDelta[aIn_, bIn_] := Module[{a = aIn, b = bIn, m, p, heads, tails, groups, h, g, gy, sums, zero},
  m = a["m"]; p = a["p"];
  {heads, tails, groups} = junctionIndex[Length[First[a["tail_e"]]], Length[First[b["head_e"]]], a["lags"]];
  If[heads === {}, {0., 0 a["pairs"]},
    h = (shifted[b["head_e"], -a["exp_e"]] - a["k_e"])[[All, heads]];
    g = (shifted[a["tail_e"], -a["exp_e"]] - a["k_e"])[[All, tails]];
    zero = ConstantArray[0., m];
    If[p > 0,
      gy = (shifted[a["tail_y"], -a["exp_y"]] - a["k_y"])[[All, tails]];
      sums = groupSums[Join[h g, h, g, gy, h[[jointIndex[m, p]]] gy], groups],
      sums = groupSums[Join[h g, h, g], groups]];
    {Join[Flatten[sums[[1 ;; 3 m]]], If[a["gram"], ConstantArray[0., m m], {}], zero, zero,
       If[p > 0, Join[ConstantArray[0., m p], Flatten[sums[[3 m + 1 ;; 3 m + m p]]], Flatten[sums[[3 m + m p + 1 ;;]]]], {}]],
     Last /@ groups}]];

(* Columns side by side: {m x k, m x l} -> m x (k + l). *)
joinColumns[x_, y_] := MapThread[Join, {x, y}];

(* The first L rows of the first record, the last L rows of the last one and the record lengths
   of the concatenation. *)
joinBoundaries[aIn_, bIn_, join_] := Module[{a = aIn, b = bIn, lags, singleA, singleB, headRows, extra, fromA, tailRows, joined},
  lags = a["lags"];
  singleA = a["segments"] == 1; singleB = b["segments"] == 1;
  headRows = Length[First[a["head_e"]]];
  If[join && singleA && headRows < lags,
    extra = Min[lags - headRows, Length[First[b["head_e"]]]];
    put[a, "head_e", joinColumns[a["head_e"], (Take[#, extra] &) /@ b["head_e"]]]];
  If[join && singleB,
    tailRows = Length[First[a["tail_e"]]];
    fromA = Min[tailRows, lags - Length[First[b["tail_e"]]]];
    put[a, "tail_e", joinColumns[(Take[#, -fromA] &) /@ a["tail_e"], b["tail_e"]]];
    If[a["p"] > 0, put[a, "tail_y", joinColumns[(Take[#, -fromA] &) /@ a["tail_y"], b["tail_y"]]]],
    put[a, "tail_e", b["tail_e"]];
    put[a, "tail_y", b["tail_y"]]];
  If[join,
    joined = a["last_length"] + b["first_length"];
    put[a, "longest", Max[a["longest"], b["longest"], joined]];
    If[singleA, put[a, "first_length", joined]];
    put[a, "last_length", If[singleB, joined, b["last_length"]]];
    put[a, "segments", a["segments"] + b["segments"] - 1],
    put[a, "longest", Max[a["longest"], b["longest"]]];
    put[a, "last_length", b["last_length"]];
    put[a, "segments", a["segments"] + b["segments"]]];
  put[a, "end_break", b["end_break"]];
  a];

(* The state of a's rows followed by b's: both moved to their combined mean (Chan's pairwise
   update), the junction's products added unless a segment break lies there, and b's sums added.
   The running sums take one compensated addition per merge: the corrections that move a and b,
   the junction's products and b's sums are added together first, and b's own compensation term is
   carried over (each compensated step costs Mathics3 seven whole-vector operations). *)
streamMerge[aIn_, bIn_] := Module[{a = aIn, b = bIn, w, ea, ta, ya, eb, tb, yb, ke, kt, ky, join, delta, junction,
    ee, et, ey},
  (* both operands in the units of the larger exponent of each column *)
  {ee, et, ey} = MapThread[Max, #] & /@ {{a["exp_e"], b["exp_e"]}, {a["exp_t"], b["exp_t"]}, {a["exp_y"], b["exp_y"]}};
  a = rescaleState[a, ee, et, ey]; b = rescaleState[b, ee, et, ey];
  w = b["n"]/(a["n"] + b["n"]);
  {ea, ta, ya} = meansOf[a]; {eb, tb, yb} = meansOf[b];
  {ke, kt, ky} = {ea + w (eb - ea), ta + w (tb - ta), ya + w (yb - ya)};
  delta = recentreDelta[a, ke, kt, ky] + recentreDelta[b, ke, kt, ky] + b["sums"][[1]];
  a = Join[a, <|"k_e" -> ke, "k_t" -> kt, "k_y" -> ky|>];
  join = ! (a["end_break"] || b["start_break"]);
  junction = If[join, junctionDelta[a, b], {0., 0 a["pairs"]}];
  put[a, "sums", compAdd[a["sums"], comp[delta + junction[[1]], b["sums"][[2]]]]];
  put[a, "pairs", a["pairs"] + b["pairs"] + junction[[2]]];
  put[a, "n", a["n"] + b["n"]];
  Scan[Function[x,
    put[a, "min_" <> x, MapThread[Min, {a["min_" <> x], b["min_" <> x]}]];
    put[a, "max_" <> x, MapThread[Max, {a["max_" <> x], b["max_" <> x]}]]], {"e", "t", "y"}];
  joinBoundaries[a, b, join]];

(* ------------------------------------------------------------------ the metrics from the sums *)

(* Every sum is moved to the overall mean first (means are overall, lags stay inside records),
   then the in-memory definitions apply, with the same degenerate values. *)
streamMetrics[sIn_, maxLag_, nParams_, noiseModel_] := Module[
  {s = sIn, m, p, n, v, nl, cur, lag, prod, a, meanE, eConstant, cov, ssc, sumT, sqT, tConstant, tss,
   sse, acf, out, joint, lagY, prodEY, sqY, b, yConstant, ssY, aj, c0, rho, dead,
   f, nObs, nVec, size, total, logSize, g, c, sigma, expE, expT, top, sh},
  {m, p, n} = {s["m"], s["p"], s["n"]};
  (* the sums are in units 2^exp of their columns: ratios are formed in them, sums of squares,
     means and variances are put back with their exponents (restore: IEEE where they leave float64) *)
  expE = s["exp_e"]; expT = s["exp_t"];
  v = val[s["sums"]];
  nl = s["pairs"][[1 ;; maxLag + 1]];
  cur = lagMatrix[s, v, "cur_e"][[All, 1 ;; maxLag + 1]];
  lag = lagMatrix[s, v, "lag_e"][[All, 1 ;; maxLag + 1]];
  prod = lagMatrix[s, v, "prod_e"][[All, 1 ;; maxLag + 1]];
  (* a = mean - K: small, because the centres follow the running means *)
  a = cur[[All, 1]]/n;
  meanE = s["k_e"] + a;
  eConstant = MapThread[Equal, {s["min_e"], s["max_e"]}];
  cov = prod - a (cur + lag) + outer[a^2, nl];   (* Sum (e_t - mean)(e_(t-l) - mean) over the pairs *)
  ssc = MapThread[If[#2, 0., Max[#1, 0.]] &, {cov[[All, 1]], eConstant}];
  sumT = sumsPart[s, v, "sum_t"]; sqT = sumsPart[s, v, "sq_t"];
  tConstant = MapThread[Equal, {s["min_t"], s["max_t"]}];
  tss = MapThread[If[#2, 0., Max[#1, 0.]] &, {sqT - sumT^2/n, tConstant}];
  sse = ssc + n meanE^2;   (* two terms >= 0: nothing cancels *)
  acf = MapThread[If[#3 || #2 == 0, ConstantArray[Indeterminate, maxLag + 1],
      Prepend[Rest[(#1/nl)/(#2/n)], 1.]] &, {cov, ssc, eConstant}];
  out = <|"sse" -> MapThread[restore[#1, 2 #2] &, {sse, expE}],
    "rmse" -> MapThread[restore[Sqrt[#1/n], #2] &, {sse, expE}],
    "max_abs_error" -> MapThread[Max[Abs[#1], Abs[#2]] &, {s["min_e"], s["max_e"]}],
    "vaf" -> MapThread[degenerate[If[#3, 0., 100. (1. - restore[#1/#2, #5])], #3, #4] &,
      {ssc, tss, tConstant, eConstant, 2 (expE - expT)}],
    "fit_percent" -> MapThread[degenerate[If[#3, 0., 100. (1. - Sqrt[restore[#1/#2, #4]])], #3, #1 == 0] &,
      {sse, tss, tConstant, 2 (expE - expT)}],
    "r2" -> MapThread[degenerate[If[#3, 0., 1. - restore[#1/#2, #4]], #3, #1 == 0] &,
      {sse, tss, tConstant, 2 (expE - expT)}],
    "residual_mean" -> MapThread[restore, {meanE, expE}],
    "residual_variance" -> MapThread[restore[#1/(n - 1), 2 #2] &, {ssc, expE}], "autocorrelation" -> transpose[acf]|>;
  If[p > 0,
    joint = jointIndex[m, p];
    lagY = lagMatrix[s, v, "lag_y"][[All, 1 ;; maxLag + 1]];
    prodEY = lagMatrix[s, v, "prod_ey"][[All, 1 ;; maxLag + 1]];
    sqY = sumsPart[s, v, "sq_y"];
    b = lagY[[All, 1]]/n;
    yConstant = MapThread[Equal, {s["min_y"], s["max_y"]}];
    ssY = MapThread[If[#2, 0., Max[#1, 0.]] &, {sqY - lagY[[All, 1]]^2/n, yConstant}];
    aj = a[[joint]];
    c0 = prodEY - b cur[[joint]] - aj lagY + outer[aj b, nl];
    dead = MapThread[#1 || #2 || #3 == 0 || #4 == 0 &, {yConstant, eConstant[[joint]], ssc[[joint]], ssY}];
    (* two roots, not the root of the product (contract 1.3), as crossCorrelation *)
    rho = MapThread[If[#4, ConstantArray[Indeterminate, maxLag + 1], (#1/nl)/(Sqrt[#2/n] Sqrt[#3/n])] &,
      {c0, ssc[[joint]], ssY, dead}];
    put[out, "rho", Partition[rho, p]]];
  Switch[noiseModel,
    "pooled",
      nObs = n m; nVec = nObs;
      top = Max[Append[Pick[expE, (# > 0 &) /@ sse], -Infinity]]; top = If[top === -Infinity, 0, top];
      total = Total[shifted[sse, 2 (expE - top)]];
      If[total == 0, f = -Infinity; size = 0., size = restore[total/nObs, 2 top]; f = nObs (Log[total/nObs] + 2 top Log[2.])],
    "per_joint",
      nObs = n; nVec = n;
      If[Min[sse] == 0, f = -Infinity; size = 0.,
        logSize = Total[Log[sse/n] + 2 expE Log[2.]]; f = n logSize; size = safeExp[logSize]],
    _,
      nObs = n; nVec = n;
      (* E'E/N is not demeaned: the centred products plus the outer product of the means *)
      (* one exponent for the whole matrix, the largest joint's *)
      g = Partition[sumsPart[s, v, "products"], m]; c = cur[[All, 1]];
      top = Max[expE]; sh = expE - top;
      sigma = transpose[shifted[transpose[shifted[g - outer[c, c]/n, sh]], sh]]/n
        + outer[shifted[meanE, sh], shifted[meanE, sh]];
      sigma = (sigma + transpose[sigma])/2.;
      logSize = logDetFull[sigma, m];
      If[logSize =!= -Infinity, logSize = logSize + 2 top m Log[2.]];
      If[logSize === -Infinity, f = -Infinity; size = 0., f = n logSize; size = safeExp[logSize]]];
  Join[out, Association @@ assemble[f, nVec, nObs, nParams, size]]];

(* ------------------------------------------------------------------ the accumulator *)

accState[ValidationAccumulator[s_]] := s;

validationAccumulator[nParams_, maxLag_, opts : OptionsPattern[]] := guard @ Module[{o},
  o = optionValues[{opts}, {"noise_model" -> "pooled"}];
  checkNParams[nParams];
  If[! (int64Q[maxLag] && maxLag >= 0), paramFail["max_lag", "an integer with max_lag >= 0", maxLag]];
  ValidationAccumulator[<|"n_params" -> nParams, "max_lag" -> maxLag,
    "noise_model" -> choice["noise_model", o["noise_model"], {"pooled", "per_joint", "full"}],
    "m" -> None, "p" -> None, "sums" -> None, "break_first" -> False, "chunks" -> 0, "rows" -> 0|>]];

accumulatorSamples[acc_ValidationAccumulator] := With[{s = accState[acc]["sums"]}, If[s === None, 0, s["n"]]];

(* Rows already checked, joint-major: e and t m x c, y m p x c ({} without a regressor). Each call
   is one block of sums, merged at once: nothing is kept of the rows but the first and last L. *)
addRows[acc_, eIn_, tIn_, yIn_] := Module[{s = accState[acc], e = eIn, t = tIn, y = yIn, block, c},
  c = Length[First[e]];
  put[s, "chunks", s["chunks"] + 1];
  If[c > 0,
    If[s["m"] === None, put[s, "m", Length[e]]; put[s, "p", If[y === {}, 0, Length[y]/Length[e]]]];
    put[s, "rows", s["rows"] + c];
    block = streamBlock[s["p"], s["max_lag"], s["noise_model"] === "full", e, t, y];
    If[s["sums"] === None,
      put[s, "sums", Append[block, "start_break" -> s["break_first"]]],
      put[s, "sums", streamMerge[s["sums"], block]]]];
  ValidationAccumulator[s]];

accumulatorUpdate[acc_ValidationAccumulator, meas_, pred_] := updateChecked[acc, meas, pred, None];
accumulatorUpdate[acc_ValidationAccumulator, meas_, pred_, regressor_] := updateChecked[acc, meas, pred, regressor];

(* The data checks of a chunk (contract 2.1, 4.1) with the message prefixed "chunk i: ". *)
updateChecked[acc_, measIn_, predIn_, regressorIn_] := Module[{meas = measIn, pred = predIn, regressor = regressorIn, s = accState[acc], r},
  r = Catch[Module[{a, b, da, db, m, c, yDims, p = 0, y = {}, bad},
      da = checkType[meas, "tau_meas"]; db = checkType[pred, "tau_pred"];
      If[regressor =!= None, yDims = checkType[regressor, "regressor"]];
      a = signal[meas, da, "tau_meas"]; b = signal[pred, db, "tau_pred"];
      If[Dimensions[a] =!= Dimensions[b],
        fail["ShapeMismatch", "tau_meas and tau_pred must have the same shape, got " <> shapeString[da] <> " and " <> shapeString[db]]];
      {m, c} = {Length[a], Length[First[a]]};
      If[s["m"] =!= None && m != s["m"],
        fail["ShapeMismatch", "tau_meas must have m=" <> ToString[s["m"]] <> " columns like the chunks before it, got shape " <> shapeString[da]]];
      If[s["m"] =!= None && (regressor =!= None) =!= (s["p"] > 0),
        fail["ShapeMismatch", "regressor must be given with every chunk or with none; the chunks before it had " <>
          If[s["p"] > 0, "one", "none"]]];
      If[regressor =!= None,
        If[Length[yDims] =!= 3 || yDims[[3]] == 0,
          fail["InvalidShape", "regressor must be 3-D (c, m, p), got shape " <> shapeString[yDims]]];
        If[yDims[[1]] != c || yDims[[2]] != m,
          fail["ShapeMismatch", "regressor must have shape (c, m, p) = (" <> ToString[c] <> ", " <> ToString[m] <>
            ", p) to match tau_meas, got " <> shapeString[yDims]]];
        p = yDims[[3]];
        If[s["p"] =!= None && p != s["p"],
          fail["ShapeMismatch", "regressor must have p=" <> ToString[s["p"]] <> " columns like the chunks before it, got shape " <> shapeString[yDims]]];
        y = transpose[Partition[Flatten[regressor], m p]]];
      Scan[(bad = firstBad[#[[2]]]; If[bad =!= None, nonFiniteFail[#[[1]], bad, #[[3]]]]) &,
        {{"tau_meas", a, None}, {"tau_pred", b, None}, {"regressor", y, If[p > 0, p, None]}}];
      {a - b, a, y}], $dvTag];
  Which[
    Head[r] === DynValError, DynValError[r[[1]], "chunk " <> ToString[s["chunks"]] <> ": " <> r[[2]]],
    r[[2]] === {} || Length[First[r[[2]]]] == 0, ValidationAccumulator[Append[s, "chunks" -> s["chunks"] + 1]],
    True, addRows[acc, Sequence @@ r]]];

accumulatorBreak[acc_ValidationAccumulator] := Module[{s = accState[acc]},
  (* breaks before any row, or repeated, make no empty record *)
  If[s["sums"] === None, put[s, "break_first", True], put[s, "sums", Append[s["sums"], "end_break" -> True]]];
  ValidationAccumulator[s]];

accumulatorMerge[acc_ValidationAccumulator, later_ValidationAccumulator] := guard @ Module[{s = accState[acc], t = accState[later]},
  Scan[If[s[#] =!= t[#], fail["InvalidParameter", "other must be a ValidationAccumulator with the same settings, got " <>
      # <> "=" <> pyRepr[t[#]] <> " where this one has " <> # <> "=" <> pyRepr[s[#]]]] &, {"n_params", "max_lag", "noise_model"}];
  If[s["m"] =!= None && t["m"] =!= None && (s["m"] != t["m"] || s["p"] != t["p"]),
    fail["ShapeMismatch", "other must hold data of the same shape, got m=" <> ToString[t["m"]] <> " joints and p=" <>
      ToString[t["p"]] <> " regressor columns where this one has m=" <> ToString[s["m"]] <> " and p=" <> ToString[s["p"]]]];
  If[s["m"] === None, put[s, "m", t["m"]]; put[s, "p", t["p"]]];
  Which[
    t["sums"] === None, If[t["break_first"], s = accState[accumulatorBreak[ValidationAccumulator[s]]]],
    s["sums"] === None, put[s, "sums", Append[t["sums"], "start_break" -> (t["sums"]["start_break"] || s["break_first"])]],
    True, put[s, "sums", streamMerge[s["sums"], t["sums"]]]];
  put[s, "chunks", s["chunks"] + t["chunks"]];
  put[s, "rows", s["rows"] + t["rows"]];
  ValidationAccumulator[s]];

accumulatorResult[acc_ValidationAccumulator] := guard @ Module[{s = accState[acc], n},
  n = If[s["sums"] === None, 0, s["sums"]["n"]];
  If[n < 2, fail["TooFewSamples", "ValidationAccumulator.result needs at least 2 samples, got N=" <> ToString[n]]];
  checkIntRange["max_lag", s["max_lag"], 0, s["sums"]["longest"], "an integer with 0 <= max_lag < " <> ToString[s["sums"]["longest"]]];
  streamMetrics[s["sums"], s["max_lag"], s["n_params"], s["noise_model"]]];

(* ------------------------------------------------------------------ the protocol operation accumulate *)

(* The exclusive ends (0-based) of the blocks: chunks is a non-empty list of positive lengths summing to N. *)
blockEnds[chunks_, n_] := If[ListQ[chunks] && chunks =!= {} && AllTrue[chunks, int64Q[#] && # >= 1 &] && Total[chunks] == n,
  accumulate[chunks], paramFail["chunks", "a non-empty list of positive lengths summing to N=" <> ToString[n], chunks]];

(* Rows lo+1..hi to one accumulator, split where a record starts inside the block with a break
   between the parts; a record starting at the block's first row is a break before it. *)
feedBlock[accIn_, colsIn_, lo_, hi_, recordStarts_] := Module[{acc = accIn, cols = colsIn, cuts, from = lo},
  If[MemberQ[recordStarts, lo], acc = accumulatorBreak[acc]];
  cuts = Append[Select[recordStarts, lo < # < hi &], hi];
  Do[
    acc = addRows[acc, Sequence @@ (If[# === {}, {}, #[[All, from + 1 ;; cuts[[k]]]]] & /@ cols)];
    If[k < Length[cuts], acc = accumulatorBreak[acc]];
    from = cuts[[k]],
    {k, Length[cuts]}];
  acc];

(* One accumulator from the blocks' own in the order merge names (a + b is accumulatorMerge[a, b]). *)
combine[partsIn_, order_] := Module[{parts = partsIn}, Switch[order,
  "none" | "left", Fold[accumulatorMerge, First[parts], Rest[parts]],
  "right", Fold[accumulatorMerge[#2, #1] &, Last[parts], Reverse[Most[parts]]],
  _, NestWhile[Function[level, If[Length[level] == 1, level,
      Join[accumulatorMerge @@@ Partition[level, 2], If[OddQ[Length[level]], {Last[level]}, {}]]]], parts, Length[#] > 1 &][[1]]]];

streamAccumulate[measIn_, predIn_, regressorIn_, nParams_, maxLag_, opts : OptionsPattern[]] := guard @ Module[
  {meas = measIn, pred = predIn, regressor = regressorIn, hasY, o, a, b, da, db, yDims, n, m, p = 0, y = {}, bad, ends, order, starts, lag, model,
   recordStarts, empty, parts = {}, lo = 0, cols},
  hasY = regressor =!= None;
  o = optionValues[{opts}, {"chunks" -> None, "merge" -> "none", "segments" -> None, "noise_model" -> "pooled", "nan_policy" -> "raise"}];
  (* the data checks of criteria and cross_correlation, in the protocol's order; "omit" is refused
     after them: a refused policy must not hide a non-finite value *)
  da = checkType[meas, "tau_meas"]; db = checkType[pred, "tau_pred"];
  If[hasY, yDims = checkType[regressor, "regressor"]];
  a = signal[meas, da, "tau_meas"]; b = signal[pred, db, "tau_pred"];
  If[hasY && (Length[yDims] =!= 3 || yDims[[3]] == 0),
    fail["InvalidShape", "regressor must be 3-D (N, m, p) with p >= 1, got shape " <> shapeString[yDims]]];
  If[Dimensions[a] =!= Dimensions[b],
    fail["ShapeMismatch", "tau_meas and tau_pred must have the same shape, got " <> shapeString[da] <> " and " <> shapeString[db]]];
  {m, n} = Dimensions[a];
  If[hasY && (yDims[[1]] != n || yDims[[2]] != m),
    fail["ShapeMismatch", "regressor must have shape (N, m, p) = (" <> ToString[n] <> ", " <> ToString[m] <>
      ", p) to match tau_meas, got " <> shapeString[yDims]]];
  checkMinSamples["accumulate", n, 2];
  If[hasY, p = yDims[[3]]; y = transpose[Partition[Flatten[regressor], m p]]];
  Scan[(bad = firstBad[#[[2]]]; If[bad =!= None, nonFiniteFail[#[[1]], bad, #[[3]]]]) &,
    {{"tau_meas", a, None}, {"tau_pred", b, None}, {"regressor", y, If[hasY, p, None]}}];
  choice["nan_policy", o["nan_policy"], {"raise"}];
  ends = blockEnds[o["chunks"], n];
  order = choice["merge", o["merge"], {"none", "left", "right", "tree"}];
  starts = parseSegments[o["segments"], n];
  checkNParams[nParams];
  lag = checkIntRange["max_lag", maxLag, 0, Max[segmentLengths[starts, n]],
    "an integer with 0 <= max_lag < " <> ToString[Max[segmentLengths[starts, n]]]];
  model = choice["noise_model", o["noise_model"], {"pooled", "per_joint", "full"}];
  recordStarts = Select[starts, # > 0 &];
  empty = validationAccumulator[nParams, lag, "noise_model" -> model];
  cols = {a - b, a, y};
  Do[
    If[parts === {} || order =!= "none", parts = Append[parts, empty]];
    parts = Append[Most[parts], feedBlock[Last[parts], cols, lo, hi, recordStarts]];
    lo = hi,
    {hi, ends}];
  accumulatorResult[combine[parts, order]]];

End[];
EndPackage[];
