(* Unit tests of DynVal and its protocol layer, as VerificationTest[...] expressions.
   Run:  cd wolfram && mathics -q -f Tests.wl   (exit status 1 when a test fails).
   Expected values are worked out by hand or are textbook values, not produced by this code. *)

Get["DynVal.wl"];
Get["Protocol.wl"];

$results = {};

(* Mathics3 10 has no VerificationTest: there the same comparison is defined here, returning the
   outcome the way Mathematica's TestResultObject does (result["Outcome"]). *)
If[! MemberQ[Attributes[VerificationTest], Protected],
  SetAttributes[VerificationTest, HoldAllComplete];
  Options[VerificationTest] = {SameTest -> SameQ, TestID -> None};
  VerificationTest[input_, expected_, opts___Rule] := Module[
    {got = Quiet[input], same = SameTest /. {opts} /. Options[VerificationTest]},
    <|"Outcome" -> If[TrueQ[same[got, expected]], "Success", "Failure"], "ActualOutput" -> got,
      "ExpectedOutput" -> expected, "TestID" -> (TestID /. {opts} /. Options[VerificationTest])|>]];

SetAttributes[check, HoldAll];
check[name_, expr_, expected_, sameQ_ : SameQ] := Module[
  {r = VerificationTest[expr, expected, SameTest -> sameQ, TestID -> name]},
  AppendTo[$results, {name, r["Outcome"] === "Success", r["ActualOutput"], expected}]];

near[tol_][a_, b_] := Which[
  ListQ[a] && ListQ[b], Length[a] == Length[b] && And @@ MapThread[near[tol], {a, b}],
  NumberQ[a] && NumberQ[b], Abs[a - b] <= tol (1 + Abs[b]),
  True, a === b];
approx = near[1.*^-12];
kindOf[r_] := If[Head[r] === DynVal`DynValError, First[r], r];

(* ---- point metrics: the lesson's scalar example (build notes, Java and numpy agree) *)
meas = {1.0, 2.5, 3.2, 4.1, 4.8, 6.1};
pred = {1.1, 2.4, 3.0, 4.3, 4.7, 6.0};
check["rmse per_element", DynVal`rmse[meas, pred], 0.14142135623730953, approx];
check["vaf pooled", DynVal`vaf[meas, pred], 99.29467897521003, approx];
check["fit_percent pooled", DynVal`fitPercent[meas, pred], 91.35818018681002, approx];
check["r2 pooled", DynVal`r2[meas, pred], 0.9925318950316357, approx];
check["aic pooled", DynVal`aic[meas, pred, "n_params" -> 2], -19.472138032568875, approx];
check["bic pooled", DynVal`bic[meas, pred, "n_params" -> 2], -19.888619094112766, approx];
check["sse by hand", DynVal`sse[{{1., 2.}, {3., 4.}}, {{1., 1.}, {3., 2.}}], 5., approx];
check["sse raw_values", DynVal`sse[{{1., 2.}, {3., 4.}}, {{1., 1.}, {3., 2.}}, "multioutput" -> "raw_values"], {0., 5.}, approx];
check["rmse per_sample", DynVal`rmse[{{1., 1.}, {1., 1.}}, {{0., 0.}, {0., 0.}}, "convention" -> "per_sample"], Sqrt[2.], approx];
check["rmse uniform_average", DynVal`rmse[{{1., 1.}, {1., 3.}}, {{0., 0.}, {0., 0.}}, "multioutput" -> "uniform_average"],
  (1. + Sqrt[5.])/2, approx];
check["max_abs_error", DynVal`maxAbsError[{1., 2., 3.}, {1.5, 2., 1.}], 2., approx];
check["residuals keep 1-D", DynVal`residuals[{1., 2.}, {0.5, 2.5}], {0.5, -0.5}, approx];
check["residuals (N,) and (N,1) are one signal", DynVal`residuals[{1., 2.}, {{0.5}, {2.5}}], {{0.5}, {-0.5}}, approx];
check["r2 by hand", DynVal`r2[{1., 2., 3.}, {1., 2., 4.}], 0.5, approx];
check["vaf by hand", DynVal`vaf[{1., 2., 3., 4.}, {1.1, 1.9, 3.1, 3.9}], 99.2, approx];

(* ---- degenerate values (contract 3.2) *)
check["r2 constant target, not exact", DynVal`r2[{2., 2., 2.}, {1., 2., 3.}], -Infinity];
check["r2 constant target, exact", DynVal`r2[{2., 2., 2.}, {2., 2., 2.}], Indeterminate];
check["fit exact", DynVal`fitPercent[{0., 2.}, {0., 2.}], 100., approx];
check["aic exact fit is -Infinity", DynVal`aic[{1., 2., 3.}, {1., 2., 3.}, "n_params" -> 1], -Infinity];
check["lesson validateDynamicsModel exact fit", DynVal`validateDynamicsModel[{1., 2., 3.}, {1., 2., 3.}, 30]["AIC"], -Infinity];
check["lesson validateDynamicsModel mismatch", DynVal`validateDynamicsModel[{1., 2., 3.}, {1., 2.}, 3], $Failed];
check["lesson validateDynamicsModel VAF is a number", DynVal`validateDynamicsModel[meas, pred, 2]["VAF"], 99.29467897521003, approx];
check["variance_weighted all constant", DynVal`r2[{{1., 2.}, {1., 2.}}, {{1., 2.}, {1., 3.}}, "multioutput" -> "variance_weighted"],
  Indeterminate];

(* ---- residual statistics *)
check["residual_mean", DynVal`residualMean[{{1., 0.}, {3., 1.}}], {2., 0.5}, approx];
check["residual_variance ddof 1", DynVal`residualVariance[{1., 2., 3.}], {1.}, approx];
check["residual_variance ddof 0", DynVal`residualVariance[{1., 2., 3.}, "ddof" -> 0], {2./3}, approx];
check["zero_mean_test df_iid", DynVal`zeroMeanTest[{0.1, -0.2, 0.15, -0.05, 0., 0.02}]["df_iid"], 5];
(* t = 1 with 1 degree of freedom: two-sided p = 1/2 (Cauchy) *)
check["t p-value, Cauchy", DynVal`Private`tTwoSided[1., 1.], 0.5, near[1.*^-13]];
(* t = 2 with 2 degrees of freedom: p = 1 - 2/Sqrt[6] *)
check["t p-value, 2 df", DynVal`Private`tTwoSided[2., 2.], 1. - 2./Sqrt[6.], near[1.*^-13]];

(* ---- autocorrelation and bands *)
check["acf biased by hand", DynVal`autocorrelation[{1., -1., 1., -1.}, 1, "adjusted" -> False], {1., -0.75}, approx];
check["acf adjusted by hand", DynVal`autocorrelation[{1., -1., 1., -1.}, 1], {1., -1.}, approx];
check["acf segments break products", DynVal`autocorrelation[{1., -1., 1., -1.}, 1, "adjusted" -> False, "segments" -> {2, 2}],
  {1., -0.5}, approx];
check["lesson residualAutocorrelation", DynVal`residualAutocorrelation[{1., -1., 1., -1.}, 1], {1., -1.}, approx];
check["acf constant residual", DynVal`autocorrelation[{1., 1., 1.}, 1], {Indeterminate, Indeterminate}];
check["confidence band n=100", DynVal`confidenceBand[100], 0.1959963984540054, approx];

(* ---- portmanteau tests *)
check["box_pierce by hand", DynVal`boxPierce[{1., -1., 1., -1.}, 1]["statistic"], {{2.25}}, approx];
(* chi-square with 2 degrees of freedom: sf(q) = Exp[-q/2] *)
check["chi2 sf, 2 df", DynVal`Private`chi2SF[3., 2], Exp[-1.5], near[1.*^-13]];
check["chi2 log sf deep tail, 2 df", DynVal`chi2LogSF[3000., 2], -1500., near[1.*^-13]];
(* 4 degrees of freedom: sf(q) = Exp[-q/2] (1 + q/2) *)
check["chi2 log sf deep tail, 4 df", DynVal`chi2LogSF[2000., 4], -1000. + Log[1001.], near[1.*^-13]];
check["chi2 sf, 4 df, series side", DynVal`Private`chi2SF[1., 4], Exp[-0.5] 1.5, near[1.*^-13]];

(* ---- cross-correlation *)
check["cross_correlation identical series", DynVal`crossCorrelation[{1., -1., 2., 0.}, {{{1.}}, {{-1.}}, {{2.}}, {{0.}}}, 0]["rho"],
  {{{1.}}}, approx];
check["cross_correlation stacked needs n_joints", kindOf[DynVal`crossCorrelation[{1., -1., 2., 0.}, {{1.}, {-1.}, {2.}, {0.}}, 0]],
  "InvalidShape"];

(* ---- information criteria: the lesson's problem 4 *)
check["information_criteria aic", DynVal`informationCriteria[10., 1000, 6]["aic"], -4593.170185988091, near[1.*^-12]];
check["information_criteria aicc p >= n-1", kindOf[DynVal`informationCriteria[1., 3, 2]], "InvalidParameter"];
check["criteria full exact is -Infinity", DynVal`criteria[{{1., 2.}, {3., 4.}, {5., 7.}}, {{1., 2.}, {3., 4.}, {5., 7.}}, "n_params" -> 1,
  "noise_model" -> "full"]["aic"], -Infinity];

(* ---- errors, kinds and check order *)
check["type", kindOf[DynVal`r2[None, {1., 2.}]], "InvalidType"];
check["type: string", kindOf[DynVal`r2["abc", {1., 2.}]], "InvalidType"];
check["shape: 0-d", kindOf[DynVal`r2[1., {1., 2.}]], "InvalidShape"];
check["shape: zero columns", kindOf[DynVal`r2[{{}, {}}, {{}, {}}]], "InvalidShape"];
check["mismatch", kindOf[DynVal`r2[{1., 2., 3.}, {1., 2.}]], "ShapeMismatch"];
check["too few", kindOf[DynVal`r2[{1.}, {1.}]], "TooFewSamples"];
check["non-finite", kindOf[DynVal`r2[{1., Indeterminate}, {1., 2.}]], "NonFiniteInput"];
check["out of range", kindOf[DynVal`r2[{1., 2.*^144}, {1., 2.}]], "NonFiniteInput"];
check["non-finite beats parameter", kindOf[DynVal`r2[{1., Infinity}, {1., 2.}, "multioutput" -> "bogus"]], "NonFiniteInput"];
check["parameter", kindOf[DynVal`r2[{1., 2.}, {1., 2.}, "multioutput" -> "bogus"]], "InvalidParameter"];
check["parameter message", DynVal`sse[{1., 2.}, {1., 2.}, "multioutput" -> "uniform_average"],
  DynVal`DynValError["InvalidParameter", "multioutput must be one of 'pooled', 'raw_values' for sse, got 'uniform_average'"]];
check["boolean is not an integer", kindOf[DynVal`autocorrelation[{1., 2., 3.}, True]], "InvalidParameter"];
check["integral float is not an integer", kindOf[DynVal`residualVariance[{1., 2., 3.}, "ddof" -> 1.]], "InvalidParameter"];
check["omit deletes rows", DynVal`sse[{1., Indeterminate, 3.}, {0., 0., 0.}, "nan_policy" -> "omit"], 10., approx];
check["omit then too few", kindOf[DynVal`r2[{1., Indeterminate}, {1., 2.}, "nan_policy" -> "omit"]], "TooFewSamples"];
check["segments as starts", DynVal`Private`parseSegments[{0, 500}, 800], {0, 500}];

(* ---- centred lagged sums (one exact integer product) against the sums written out *)
directSums[x_, y_, maxLag_, starts_] := Module[{bounds = Transpose[{starts, Append[Rest[starts], Length[x]]}],
    dx = x - Mean[x], dy = y - Mean[y]},
  Table[Total[If[#[[2]] - #[[1]] > lag, Total[dx[[#[[1]] + lag + 1 ;; #[[2]]]] dy[[#[[1]] + 1 ;; #[[2]] - lag]]], 0.] & /@ bounds],
    {lag, 0, maxLag}]];
series1 = {0.3, -1.2, 2.5, 0.7, -0.4, 1.9, -2.2, 0.05, 1.1, -0.6, 0.8, -1.7};
series2 = {1.5, 0.2, -0.9, 2.2, -1.1, 0.4, 0.6, -2.5, 1.3, 0.1, -0.3, 0.9};
check["lagged sums, one segment", DynVal`Private`laggedSums[series1, series2, 5, {0}], directSums[series1, series2, 5, {0}], near[1.*^-14]];
check["lagged sums, three segments", DynVal`Private`laggedSums[series1, series1, 4, {0, 3, 8}],
  directSums[series1, series1, 4, {0, 3, 8}], near[1.*^-14]];
check["lagged sums, lag beyond a segment", DynVal`Private`laggedSums[series1, series2, 6, {0, 3, 8}],
  directSums[series1, series2, 6, {0, 3, 8}], near[1.*^-14]];
(* 10^7 + 10^-3 s: x - 10^7 is exact in doubles, so the exact centring must agree with the sums of the small values *)
offsetSeries = 1.*^7 + 1.*^-3 series1;
check["lagged sums, large offset", DynVal`Private`laggedSums[offsetSeries, offsetSeries, 2, {0}],
  directSums[offsetSeries - 1.*^7, offsetSeries - 1.*^7, 2, {0}], near[1.*^-12]];

(* ---- protocol numbers *)
check["hex read", DynValProtocol`readReal["-0x1.8000000000000p+1"], -3.];
check["hex read subnormal", DynValProtocol`readReal["0x0.0000000000001p-1022"], 4.940656458412465*^-324];
check["decimal read", DynValProtocol`readReal["9.4999999999999996e-01"], 0.95];
check["nan and inf", DynValProtocol`readReal /@ {"NaN", "-nan", "nan(ind)", "Inf", "-infinity"},
  {Indeterminate, Indeterminate, Indeterminate, Infinity, -Infinity}];
check["not a number", DynValProtocol`readReal["1,5"], $Failed];
check["array, hex", DynValProtocol`readArray[{"real", "2", "2", "1", "0x1.0000000000000p+0", "-0x1.4000000000000p+1"}], {{1.}, {-2.5}}];
check["array, decimal", DynValProtocol`readArray[{"real", "1", "2", "1.0000000000000000e-01", "-2.5000000000000000e+00"}], {0.1, -2.5}];
(* float.hex of these values, as Python writes them *)
check["hex write", DynValProtocol`writeReal /@ {1., -2.5, 0.1, 4.940656458412465*^-324, 1.7976931348623157*^308, 0.},
  {"0x1.0000000000000p+0", "-0x1.4000000000000p+1", "0x1.999999999999ap-4", "0x0.0000000000001p-1022",
   "0x1.fffffffffffffp+1023", "0x0.0p+0"}];
(* one scale for the list, 2^57 (53 - Floor[Log2 0.1]): 0.1 = 0x1999999999999a 2^-56 = 0x33333333333334 2^-57,
   3 = 3 2^57 2^-57 = 0x600000000000000 2^-57, 0 = 0x0 2^-57 *)
check["hex write, list", DynValProtocol`Private`writeReals[{0.1, Indeterminate, 3., -Infinity, 0.}],
  {"0x33333333333334p-57", "nan", "0x600000000000000p-57", "-inf", "0x0p-57"}];
check["hex write, one value", DynValProtocol`Private`writeReals[{-0.1}], {"-0x33333333333334p-57"}];
check["hex write, no value", DynValProtocol`Private`writeReals[{}], {}];
check["array, hex, one value", DynValProtocol`readArray[{"real", "1", "1", "-0x1.8000000000000p+1"}], {-3.}];
check["array, hex with nan and zeros", DynValProtocol`readArray[{"real", "1", "5", "0x1.0000000000000p+0", "nan",
  "-0x0.0p+0", "-inf", "0x1.999999999999ap-4"}], {1., Indeterminate, 0., -Infinity, 0.1}];
extremes = {-1.7976931348623157`*^308, 2.2250738585072014`*^-308, 4.940656458412465`*^-324, 0.9999999999999999`, 1.0000000000000002`};
check["hex write, round trip of the extremes", DynValProtocol`readReal /@ DynValProtocol`Private`writeReals[extremes], extremes];
check["typed values", DynValProtocol`readValue /@ {"none", "true", "12", "\"raw_values\"", "[1,2]", "\"a%20b\""},
  {None, True, 12, "raw_values", {1, 2}, "a b"}];

(* ---- data near the ends of the double range (contract 1.3): sums of squares are scaled by a
   power of two; unscaled, the squares underflow (r2 degenerate, rmse 0, rho Indeterminate) or the
   eigenvalues of the full noise model overflow *)
rel[tol_][a_, b_] := Which[
  ListQ[a] && ListQ[b], Length[a] == Length[b] && And @@ MapThread[rel[tol], {a, b}],
  NumberQ[a] && NumberQ[b], Abs[a - b] <= tol Abs[b],
  True, a === b];
tiny = 2.^-540; huge = 2.^270;
pair2 = {{1.0, 2.0}, {2.5, 1.5}, {3.2, 0.7}, {4.1, -0.4}, {4.8, -1.2}, {6.1, -2.1}};
pred2 = {{1.1, 1.9}, {2.4, 1.6}, {3.0, 0.9}, {4.3, -0.5}, {4.7, -1.0}, {6.0, -2.3}};
check["rmse of data near 1e-163", DynVal`rmse[tiny pair2, tiny pred2] / tiny, DynVal`rmse[pair2, pred2], rel[1.*^-14]];
check["r2 of data near 1e-163", DynVal`r2[tiny pair2, tiny pred2, "multioutput" -> "raw_values"],
  DynVal`r2[pair2, pred2, "multioutput" -> "raw_values"], rel[1.*^-13]];
check["variance_weighted r2, joints at 1e-163 and 1", DynVal`r2[{1., tiny} # & /@ pair2, {1., tiny} # & /@ pred2,
  "multioutput" -> "variance_weighted"], DynVal`r2[pair2[[All, 1]], pred2[[All, 1]]], rel[1.*^-13]];
check["autocorrelation of data near 1e-301", DynVal`autocorrelation[2.^-1000 (pair2 - pred2), 3],
  DynVal`autocorrelation[pair2 - pred2, 3], rel[1.*^-13]];
check["zero-mean t of data near 1e-163", DynVal`zeroMeanTest[tiny (pair2 - pred2)]["statistic_iid"],
  DynVal`zeroMeanTest[pair2 - pred2]["statistic_iid"], rel[1.*^-13]];
check["full noise model of data near 1e81", DynVal`aic[huge pair2, huge pred2, "n_params" -> 2, "noise_model" -> "full"],
  DynVal`aic[pair2, pred2, "n_params" -> 2, "noise_model" -> "full"] + 6 2 270 2 Log[2.], rel[1.*^-13]];

(* ---- streaming accumulator (contract 4.1): every output equals the in-memory functions on the
   whole series, whatever the blocks, the merge order and the breaks; its state does not grow *)
(* one top-level evaluation of many merges would reach Mathics3's iteration count (Protocol.wl, serve) *)
$IterationLimit = 2^63 - 1;
streamData[n_, offset_] := {
  Table[offset + {5. Sin[0.3 k] + k/20., 3. Cos[0.17 k] - 2.}, {k, n}],
  Table[offset + {5. Sin[0.3 k] + k/20., 3. Cos[0.17 k] - 2.} + {0.4 Sin[1.3 k] + 0.05, 0.3 Cos[2.9 k + 1.] - 0.1 Sin[0.5 k]}, {k, n}],
  Table[{{Sin[0.2 k], Cos[0.11 k]^2}, {k/N[n], 1. + Sin[0.7 k]}}, {k, n}]};
inMemory[t_, y_, yReg_, maxLag_, nParams_, model_, segments_] := Module[{raw = "multioutput" -> "raw_values", c},
  c = DynVal`criteria[t, y, "n_params" -> nParams, "noise_model" -> model];
  Join[<|"sse" -> DynVal`sse[t, y, raw], "rmse" -> DynVal`rmse[t, y, raw], "max_abs_error" -> DynVal`maxAbsError[t, y, raw],
    "vaf" -> DynVal`vaf[t, y, raw]/100., "fit_percent" -> DynVal`fitPercent[t, y, raw]/100., "r2" -> DynVal`r2[t, y, raw],
    "residual_mean" -> DynVal`residualMean[t - y], "residual_variance" -> DynVal`residualVariance[t - y],
    "autocorrelation" -> DynVal`autocorrelation[t - y, maxLag, "segments" -> segments],
    "aic" -> c["aic"], "bic" -> c["bic"], "aicc" -> c["aicc"], "fpe" -> c["fpe"], "naic" -> c["naic"]|>,
    If[yReg === None, <||>, <|"rho" -> DynVal`crossCorrelation[t - y, yReg, maxLag, "segments" -> segments]["rho"]|>]]];
(* the stream's outputs (percentages as fractions) in the order of the in-memory ones *)
streamed[r_, want_] := If[Head[r] === DynVal`DynValError, r,
  Association @@ ((# -> If[MemberQ[{"vaf", "fit_percent"}, #], r[#]/100., r[#]]) & /@ Keys[want])];
streamCase[{t_, y_, yReg_}, maxLag_, nParams_, chunks_, order_, segments_, model_] :=
  DynVal`streamAccumulate[t, y, yReg, nParams, maxLag, "chunks" -> chunks, "merge" -> order, "segments" -> segments,
    "noise_model" -> model];
sameAs[tol_][a_, b_] := Keys[a] === Keys[b] && And @@ (near[tol][a[#], b[#]] & /@ Keys[b]);
sd = streamData[30, 0.];
wantPlain = inMemory[sd[[1]], sd[[2]], sd[[3]], 4, 3, "pooled", None];
(* random chunkings (a fixed seed): one block, one-row blocks, blocks shorter than max_lag = 4 *)
SeedRandom[20261127];
randomChunks[n_] := Module[{left = n, out = {}, c}, While[left > 0, c = Min[left, RandomInteger[{1, 9}]]; out = Append[out, c]; left -= c]; out];
Do[With[{chunks = randomChunks[30]},
  check["stream: random chunking " <> ToString[chunks], streamed[streamCase[sd, 4, 3, chunks, "none", None, "pooled"], wantPlain],
    wantPlain, sameAs[1.*^-12]]], {3}];
check["stream: one block", streamed[streamCase[sd, 4, 3, {30}, "none", None, "pooled"], wantPlain], wantPlain, sameAs[1.*^-12]];
check["stream: one-row blocks, tree", streamed[streamCase[sd, 4, 3, ConstantArray[1, 30], "tree", None, "pooled"], wantPlain],
  wantPlain, sameAs[1.*^-12]];
(* the four merge orders, with records starting at a junction (12) and inside a block (21) *)
wantSeg = inMemory[sd[[1]], sd[[2]], sd[[3]], 3, 3, "per_joint", {12, 9, 9}];
Scan[check["stream: merge " <> # <> ", breaks at a junction and inside a block",
    streamed[streamCase[sd, 3, 3, {5, 7, 3, 2, 4, 9}, #, {0, 12, 21}, "per_joint"], wantSeg], wantSeg, sameAs[1.*^-12]] &,
  {"none", "left", "right", "tree"}];
wantFull = inMemory[sd[[1]], sd[[2]], None, 3, 3, "full", {12, 18}];
check["stream: full noise model, break at a junction, no regressor",
  streamed[streamCase[{sd[[1]], sd[[2]], None}, 3, 3, {4, 8, 3, 15}, "left", {12, 18}, "full"], wantFull], wantFull, sameAs[1.*^-12]];
(* the accumulator itself: a break at a merge junction is the same as the segments *)
accA = DynVal`validationAccumulator[3, 3, "noise_model" -> "per_joint"];
accA = DynVal`accumulatorUpdate[accA, sd[[1, 1 ;; 7]], sd[[2, 1 ;; 7]], sd[[3, 1 ;; 7]]];
accA = DynVal`accumulatorUpdate[accA, sd[[1, 8 ;; 12]], sd[[2, 8 ;; 12]], sd[[3, 8 ;; 12]]];
accB = DynVal`accumulatorUpdate[DynVal`accumulatorBreak[DynVal`validationAccumulator[3, 3, "noise_model" -> "per_joint"]],
  sd[[1, 13 ;; 21]], sd[[2, 13 ;; 21]], sd[[3, 13 ;; 21]]];
accB = DynVal`accumulatorUpdate[DynVal`accumulatorBreak[accB], sd[[1, 22 ;; 30]], sd[[2, 22 ;; 30]], sd[[3, 22 ;; 30]]];
check["stream: accumulatorBreak at a merge junction and between chunks",
  streamed[DynVal`accumulatorResult[DynVal`accumulatorMerge[accA, accB]], wantSeg], wantSeg, sameAs[1.*^-12]];
check["stream: samples", DynVal`accumulatorSamples[DynVal`accumulatorMerge[accA, accB]], 30];
(* torques about 1e7 with a spread of a few units: the sums stay centred *)
sdBig = streamData[30, 1.*^7];
wantBig = inMemory[sdBig[[1]], sdBig[[2]], None, 3, 3, "pooled", None];
check["stream: large offset", streamed[streamCase[{sdBig[[1]], sdBig[[2]], None}, 3, 3, {13, 1, 9, 7}, "right", None, "pooled"], wantBig],
  wantBig, sameAs[1.*^-9]];
(* the state after 300 rows is as large as after 30 *)
sdLong = streamData[300, 0.];
feedAll[n_] := Fold[DynVal`accumulatorUpdate[#1, sdLong[[1, #2]], sdLong[[2, #2]], sdLong[[3, #2]]] &,
  DynVal`validationAccumulator[3, 4], Span @@@ Partition[Range[n], 10][[All, {1, -1}]]];
check["stream: state size independent of N", LeafCount[feedAll[300]] - LeafCount[feedAll[30]], 0];
(* errors, in the protocol's order *)
check["stream: omit refused", kindOf[DynVal`streamAccumulate[sd[[1]], sd[[2]], None, 3, 3, "chunks" -> {30}, "nan_policy" -> "omit"]],
  "InvalidParameter"];
check["stream: omit with a NaN is NonFiniteInput", kindOf[DynVal`streamAccumulate[ReplacePart[sd[[1]], {5, 2} -> Indeterminate], sd[[2]],
  None, 3, 3, "chunks" -> {30}, "nan_policy" -> "omit"]], "NonFiniteInput"];
check["stream: chunks not summing to N", DynVal`streamAccumulate[sd[[1]], sd[[2]], None, 3, 3, "chunks" -> {10, 19}],
  DynVal`DynValError["InvalidParameter", "chunks must be a non-empty list of positive lengths summing to N=30, got [10, 19]"]];
check["stream: a block of length 0", kindOf[DynVal`streamAccumulate[sd[[1]], sd[[2]], None, 3, 3, "chunks" -> {10, 0, 20}]], "InvalidParameter"];
check["stream: chunks none", kindOf[DynVal`streamAccumulate[sd[[1]], sd[[2]], None, 3, 3, "chunks" -> None]], "InvalidParameter"];
check["stream: bad merge", DynVal`streamAccumulate[sd[[1]], sd[[2]], None, 3, 3, "chunks" -> {30}, "merge" -> "sideways"],
  DynVal`DynValError["InvalidParameter", "merge must be one of 'none', 'left', 'right', 'tree', got 'sideways'"]];
check["stream: bad chunks before bad merge", kindOf[DynVal`streamAccumulate[sd[[1]], sd[[2]], None, 3, 3, "chunks" -> {3}, "merge" -> "x"]],
  "InvalidParameter"];
check["stream: max_lag below the longest record", kindOf[DynVal`streamAccumulate[sd[[1]], sd[[2]], None, 3, 18, "chunks" -> {30},
  "segments" -> {12, 18}, "merge" -> "left"]], "InvalidParameter"];
check["stream: regressor rows", kindOf[DynVal`streamAccumulate[sd[[1]], sd[[2]], Most[sd[[3]]], 3, 3, "chunks" -> {30}]], "ShapeMismatch"];
check["stream: one sample", kindOf[DynVal`streamAccumulate[sd[[1, {1}]], sd[[2, {1}]], None, 3, 0, "chunks" -> {1}]], "TooFewSamples"];
check["stream: chunk message", DynVal`accumulatorUpdate[DynVal`accumulatorUpdate[DynVal`validationAccumulator[1, 1], {{1., 2.}, {2., 1.}}, {{0., 0.}, {0., 0.}}],
  {1., 2.}, {0., 0.}], DynVal`DynValError["ShapeMismatch", "chunk 1: tau_meas must have m=2 columns like the chunks before it, got shape (2,)"]];

(* ---- report and exit status *)
failed = Select[$results, ! #[[2]] &];
Scan[WriteString[First[Streams["stdout"]], "FAILED " <> #[[1]] <> ": got " <> ToString[InputForm[#[[3]]]] <>
    ", expected " <> ToString[InputForm[#[[4]]]] <> "\n"] &, failed];
WriteString[First[Streams["stdout"]], ToString[Length[$results] - Length[failed]] <> " passed, " <>
  ToString[Length[failed]] <> " failed\n"];
Exit[If[failed === {}, 0, 1]];
