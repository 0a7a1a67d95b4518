(* ::Package:: *)

(* DynVal: validation metrics for identified robot dynamic models (tau = Y pi + eps).

   A port of dynval (docs/contract.md) following the lesson's validateDynamicsModel and
   residualAutocorrelation, multi-joint and with the contract's conventions, degenerate values
   and errors. Runs in Mathematica and in Mathics3.

   Data are lists: a signal is {x1, ..., xN} (one joint) or an N x m matrix. NaN is written
   Indeterminate and the infinities Infinity / -Infinity. Every public function returns its value,
   or DynValError[kind, message] with one of the contract's six kinds. *)

BeginPackage["DynVal`"];

DynValError::usage = "DynValError[kind, message] is returned when an input is rejected; kind is one of \
\"InvalidType\", \"InvalidShape\", \"ShapeMismatch\", \"TooFewSamples\", \"NonFiniteInput\", \"InvalidParameter\".";

residuals::usage = "residuals[tauMeas, tauPred, opts] gives e = tauMeas - tauPred.";
sse::usage = "sse[tauMeas, tauPred, \"multioutput\" -> \"pooled\"|\"raw_values\"] gives the sum of squared errors.";
rmse::usage = "rmse[tauMeas, tauPred, \"multioutput\" -> ..., \"convention\" -> None|\"per_element\"|\"per_sample\"] gives the RMSE.";
maxAbsError::usage = "maxAbsError[tauMeas, tauPred, \"multioutput\" -> ...] gives the largest absolute residual.";
vaf::usage = "vaf[tauMeas, tauPred, \"multioutput\" -> ...] gives the variance accounted for, in percent.";
fitPercent::usage = "fitPercent[tauMeas, tauPred, \"multioutput\" -> ...] gives 100(1 - Sqrt[SSE/TSS]).";
r2::usage = "r2[tauMeas, tauPred, \"multioutput\" -> ...] gives 1 - SSE/TSS.";
residualMean::usage = "residualMean[e] gives the mean of each joint's residual.";
residualVariance::usage = "residualVariance[e, \"ddof\" -> 1] gives each joint's residual variance.";
zeroMeanTest::usage = "zeroMeanTest[e, \"segments\" -> None] gives an Association with the i.i.d. and the autocorrelation-corrected t-tests.";
autocorrelation::usage = "autocorrelation[e, maxLag, \"adjusted\" -> True, \"segments\" -> None] gives rho(0..maxLag).";
confidenceBand::usage = "confidenceBand[n, \"level\" -> 0.95] gives z/Sqrt[n].";
ljungBox::usage = "ljungBox[e, lags, \"model_df\" -> 0, \"segments\" -> None] gives the Ljung-Box test as an Association.";
boxPierce::usage = "boxPierce[e, lags, \"model_df\" -> 0, \"segments\" -> None] gives the Box-Pierce test as an Association.";
crossCorrelation::usage = "crossCorrelation[e, regressor, maxLag, \"n_joints\" -> None, \"adjusted\" -> True, \"level\" -> 0.95] gives rho, constant_mask and band.";
informationCriteria::usage = "informationCriteria[rss, nObs, nParams] gives aic, bic, aicc, fpe and naic.";
criteria::usage = "criteria[tauMeas, tauPred, \"n_params\" -> p, \"noise_model\" -> \"pooled\"] gives the information criteria of the residual.";
aic::usage = "aic[tauMeas, tauPred, \"n_params\" -> p, \"noise_model\" -> ...] gives the AIC (constant dropped).";
bic::usage = "bic[tauMeas, tauPred, \"n_params\" -> p, \"noise_model\" -> ...] gives the BIC (constant dropped).";
chi2LogSF::usage = "chi2LogSF[q, df] gives the logarithm of the chi-square survival function, finite where it underflows.";
validateDynamicsModel::usage = "validateDynamicsModel[tauMeas, tauPred, pParams] is the lesson's entry point, fixed: an Association of RMSE, VAF, FitPercent, R2, AIC and BIC.";
residualAutocorrelation::usage = "residualAutocorrelation[e, L] is the lesson's adjusted autocorrelation of one joint.";

Begin["`Private`"];

$maxMagnitude = 1.*^144;

(* ------------------------------------------------------------------ errors and formatting *)

fail[kind_, msg_] := Throw[DynValError[kind, msg], $dvTag];
SetAttributes[guard, HoldFirst];
guard[body_] := Catch[body, $dvTag];

(* Python's repr of a parameter value: the contract's messages show values that way. *)
pyRepr[v_String] := "'" <> v <> "'";
pyRepr[True] = "True"; pyRepr[False] = "False"; pyRepr[None] = "None";
pyRepr[v_Integer] := ToString[v];
pyRepr[Indeterminate] = "nan"; pyRepr[DirectedInfinity[1]] = "inf"; pyRepr[DirectedInfinity[-1]] = "-inf";
pyRepr[v_Real] := Module[{s = ToString[InputForm[v]]},
  s = StringReplace[s, "*^" -> "e"];
  If[StringFreeQ[s, "."] && StringFreeQ[s, "e"], s <> ".0", If[StringTake[s, -1] === ".", s <> "0", s]]];
pyRepr[v_List] := "[" <> StringRiffle[pyRepr /@ v, ", "] <> "]";
pyRepr[v_] := ToString[v];

shapeString[{}] = "()";
shapeString[{n_}] := "(" <> ToString[n] <> ",)";
shapeString[dims_List] := "(" <> StringRiffle[ToString /@ dims, ", "] <> ")";

paramFail[param_, requirement_, value_] :=
  fail["InvalidParameter", param <> " must be " <> requirement <> ", got " <> pyRepr[value]];

(* ------------------------------------------------------------------ parameter checks *)

int64Q[v_] := IntegerQ[v] && -2^63 <= v < 2^63;
realQ[v_] := (IntegerQ[v] || Head[v] === Real || v === Indeterminate || MatchQ[v, DirectedInfinity[1 | -1]]);

choice[param_, value_, options_] :=
  If[MatchQ[value, Alternatives @@ options], value,
    paramFail[param, "one of " <> StringRiffle[("'" <> # <> "'") & /@ options, ", "], value]];

$multioutputs = {"pooled", "raw_values", "uniform_average", "variance_weighted"};

checkMultioutput[value_, allowed_, function_] := (
  choice["multioutput", value, $multioutputs];
  If[! MatchQ[value, Alternatives @@ allowed],
    paramFail["multioutput", "one of " <> StringRiffle[("'" <> # <> "'") & /@ allowed, ", "] <> " for " <> function, value]];
  value);

checkConvention[value_, multioutput_] := Which[
  value === None || value === "", "",
  multioutput =!= "pooled", paramFail["convention", "None unless multioutput='pooled'", value],
  True, choice["convention", value, {"per_element", "per_sample"}]];

checkIntRange[param_, value_, lo_, hi_, requirement_] :=
  If[int64Q[value] && lo <= value && value < hi, value, paramFail[param, requirement, value]];

checkAdjusted[value_] := If[value === True || value === False, value, paramFail["adjusted", "True or False", value]];

checkLevel[value_] := If[realQ[value] && NumericQ[value] && 0 < value < 1, N[value],
  paramFail["level", "a number with 0 < level < 1", value]];

checkNParams[value_] := If[int64Q[value] && value >= 0, value, paramFail["n_params", "an integer with n_params >= 0", value]];

(* segments: None, lengths summing to N, or starts beginning at 0; gives the starts (0-based). *)
parseSegments[segments_, n_] := Module[{bad, v = segments},
  bad := paramFail["segments", "positive lengths summing to N=" <> ToString[n] <>
      ", or increasing starts beginning at 0 and below N=" <> ToString[n], segments];
  Which[
    v === None, {0},
    ! ListQ[v] || v === {} || ! AllTrue[v, int64Q], bad,
    First[v] == 0, If[Length[v] > 1 && Min[differences[v]] <= 0 || Last[v] >= n, bad, v],
    Min[v] <= 0 || Total[v] != n, bad,
    True, Most[Prepend[accumulate[v], 0]]]];

(* Mathics3 10 transposes a 1 x k matrix into a flat list; the k x 1 matrix is meant. *)
(* Mathics3 transposes through SymPy, element by element; a few columns are taken with Part instead. *)
transpose[m_List] := Which[
  Length[m] === 1 && ListQ[First[m]], List /@ First[m],
  Length[First[m]] <= 8, Table[m[[All, j]], {j, Length[First[m]]}],
  True, Transpose[m]];

(* Differences and Accumulate written out: Mathics3 lacks the first and evaluates the second slowly. *)
differences[v_List] := Rest[v] - Most[v];

(* The smallest and the largest value. Mathics3 sorts a list of reals in one step, while Min and
   Max compare element by element through the evaluator, several times slower. *)
extremes[v_List] := With[{s = Sort[v]}, {First[s], Last[s]}];
constantQ[v_List] := Equal @@ extremes[v];
accumulate[v_List] := Module[{t = 0}, Table[t += x, {x, v}]];
segmentLengths[starts_, n_] := differences[Append[starts, n]];

(* ------------------------------------------------------------------ data checks *)

typeName[None] = "NoneType"; typeName[_String] = "str"; typeName[True | False] = "bool";
typeName[_Integer] = "int"; typeName[_Real] = "float"; typeName[_] = "object";

(* An array argument: a (nested) list of real numbers; anything else is InvalidType. *)
checkType[x_, name_] := Which[
  (* the usual case, a rectangular array of machine reals, is decided by a pattern and a count;
     ArrayQ and FreeQ would visit every element through the evaluator *)
  ListQ[x] && realArrayQ[x], Dimensions[x],
  (* a 0-d array of numbers (or booleans) is of the right type but has no axis *)
  realQ[x] || x === True || x === False, {},
  ! ListQ[x], fail["InvalidType", name <> " must be an array of real numbers, got " <> typeName[x]],
  ! ArrayQ[x], fail["InvalidType", name <> " must be an array of real numbers, got object"],
  ! FreeQ[x, _String], fail["InvalidType", name <> " must be an array of real numbers, got <U1"],
  ! FreeQ[x, _Complex], fail["InvalidType", name <> " must be an array of real numbers, got complex128"],
  ! FreeQ[x, None | True | False], fail["InvalidType", name <> " must be an array of real numbers, got object"],
  True, Dimensions[x]];

realArrayQ[x_List] := With[{flat = Flatten[x]}, MatchQ[flat, {___Real}] && Times @@ Dimensions[x] === Length[flat]];

(* (N,) -> one joint; (N, m) -> m joints. Gives the joint-major columns. *)
checkSignal[x_, name_] := signal[x, checkType[x, name], name];
signal[x_, dims_, name_] := Which[
    Length[dims] === 1, {x},
    Length[dims] =!= 2, fail["InvalidShape", name <> " must be 1-D (N,) or 2-D (N, m), got shape " <> shapeString[dims]],
    dims[[2]] === 0, fail["InvalidShape", name <> " must have at least one column, got shape " <> shapeString[dims]],
    True, transpose[x]];

checkMinSamples[function_, n_, k_] :=
  If[n < k, fail["TooFewSamples", function <> " needs at least " <> ToString[k] <> " samples, got N=" <> ToString[n]]];

inRangeQ[v_] := NumberQ[v] && Abs[v] <= $maxMagnitude;
allInRangeQ[flat_List] := Which[
  flat === {}, True,
  MatchQ[flat, {__Real}], With[{ends = extremes[flat]}, -$maxMagnitude <= First[ends] && Last[ends] <= $maxMagnitude],
  True, TrueQ[Max[flat] <= $maxMagnitude] && TrueQ[Min[flat] >= -$maxMagnitude]];

valueText[v_] := Which[v === Indeterminate, "nan", v === DirectedInfinity[1], "inf",
  v === DirectedInfinity[-1], "-inf", True, "?"];

(* The first value that is not finite and in range, row-major over the (N, k) view: {row, col, value}. *)
firstBad[cols_List] := Module[{flat, pos},
  If[allInRangeQ[Flatten[cols]], None,
    flat = Flatten[transpose[cols]];
    pos = Catch[Do[If[! inRangeQ[flat[[i]]], Throw[i, $posTag]], {i, Length[flat]}]; 0, $posTag];
    {Quotient[pos - 1, Length[cols]], Mod[pos - 1, Length[cols]], flat[[pos]]}]];

nonFiniteFail[name_, {row_, col_, value_}, nColumns_] := Module[{where},
  where = If[IntegerQ[nColumns],
    "at sample " <> ToString[row] <> ", joint " <> ToString[Quotient[col, nColumns]] <> ", column " <> ToString[Mod[col, nColumns]],
    "at row " <> ToString[row] <> ", column " <> ToString[col]];
  If[NumberQ[value],
    fail["NonFiniteInput", name <> " has a value out of range (" <> pyRepr[value] <> ") " <> where <> ": |x| must be at most 1e+144"],
    fail["NonFiniteInput", name <> " has a non-finite value (" <> valueText[value] <> ") " <> where]]];

(* The parameter step's common part (contract 2.1): nan_policy, then finiteness (raise) or omission
   (omit) after the segments are parsed. data: {{name, cols, nColumns}, ...}. Gives {colsList, starts}. *)
prepare[function_, minimum_, data_, nanPolicy_, segments_, useSegments_] := With[
  {bad = Catch[Scan[With[{b = firstBad[#[[2]]]}, If[b =!= None, Throw[{#[[1]], b, #[[3]]}, $posTag]]] &, data]; None, $posTag]},
  (* the usual case in few steps: every Mathics3 evaluation step costs, even on small data *)
  If[bad === None && ! useSegments && MatchQ[nanPolicy, "raise" | "omit"], {data[[All, 2]], {0}},
    prepareAll[function, minimum, data, nanPolicy, segments, useSegments, bad]]];

prepareAll[function_, minimum_, data_, nanPolicy_, segments_, useSegments_, bad_] := Module[
  {starts, n = Length[data[[1, 2, 1]]], keep, colsList, kept, opens, prevDeleted, isStart},
  If[! MatchQ[nanPolicy, "raise" | "omit"],
    If[bad =!= None, nonFiniteFail @@ bad];
    choice["nan_policy", nanPolicy, {"raise", "omit"}]];
  If[nanPolicy === "raise" && bad =!= None, nonFiniteFail @@ bad];
  starts = If[useSegments, parseSegments[segments, n], {0}];
  colsList = data[[All, 2]];
  If[nanPolicy === "omit" && bad =!= None,
    keep = Table[AllTrue[Flatten[#[[All, k]] & /@ colsList], inRangeQ], {k, n}];
    isStart = ReplacePart[ConstantArray[False, n], List /@ (starts + 1) -> True];
    prevDeleted = Prepend[Not /@ Most[keep], True];
    opens = Pick[MapThread[Or, {isStart, prevDeleted}], keep];
    kept = Pick[Range[n], keep];
    colsList = Map[Function[cols, #[[kept]] & /@ cols], colsList];
    starts = Flatten[Position[opens, True]] - 1;
    If[starts === {}, starts = {0}];
    checkMinSamples[function, Length[kept], minimum]];
  {colsList, starts}];

pairData[function_, minimum_, meas_, pred_] := Module[{a, b, da, db},
  da = checkType[meas, "tau_meas"]; db = checkType[pred, "tau_pred"];
  a = signal[meas, da, "tau_meas"]; b = signal[pred, db, "tau_pred"];
  If[Dimensions[a] =!= Dimensions[b],
    fail["ShapeMismatch", "tau_meas and tau_pred must have the same shape, got " <> shapeString[da] <> " and " <> shapeString[db]]];
  checkMinSamples[function, Length[First[a]], minimum];
  {a, b}];

residualData[function_, minimum_, e_] := Module[{a = checkSignal[e, "e"]},
  checkMinSamples[function, Length[First[a]], minimum]; a];

(* ------------------------------------------------------------------ kernels on joint-major columns *)

(* Corrected two-pass moments of one series: {mean, centred sum of squares, constant}. *)
moments[x_List] := Module[{n = Length[x], m1, d, s, ss, constant},
  constant = constantQ[x];
  m1 = Total[x]/n; d = x - m1; s = Total[d];
  ss = If[constant, 0., Max[Total[d d] - s s/n, 0.]];
  {m1 + s/n, ss, constant}];

(* Deviations from the mean with the mean's own rounding removed (second pass). *)
centred[x_List] := Module[{d = x - Total[x]/Length[x]}, d - Total[d]/Length[d]];

sumSq[x_List] := Total[x x];

(* Sums of squares scaled by a power of two (contract 1.3): x 2^-k, k the exponent of max |x|,
   squares without underflow or overflow, and the scaling is exact. A sum of squares is carried as
   {s, k}, its value s 4^k, so that ratios and logarithms of data near 1e-162 or 1e140 keep their
   digits. Mathics3 turns a machine overflow into Overflow[] (not Infinity): restore checks first. *)
scaleExponent[x_List] := With[{big = Max[Abs[extremes[Flatten[x]]]]}, If[big == 0, 0, Floor[Log[2., big]] + 1]];
pow2[x_, 0] := x;
pow2[x_, j_Integer] := If[Abs[j] <= 1000, x 2.^j, pow2[x 2.^(1000 Sign[j]), j - 1000 Sign[j]]];
restore[v_, j_Integer] := Which[
  ! NumberQ[v] || v == 0, v,
  Log[2., Abs[v]] + j >= 1024., Sign[v] Infinity,
  True, pow2[v, j]];
scaledSumSq[x_List] := With[{k = scaleExponent[x]}, {sumSq[pow2[x, -k]], k}];
ssValue[{s_, k_}] := restore[s, 2 k];
rootMean[{s_, k_}, d_] := restore[Sqrt[s/d], k];
logMean[{s_, k_}, d_] := Log[s/d] + 2 k Log[2.];
ssRatio[{sa_, ka_}, {sb_, kb_}] := restore[sa/sb, 2 (ka - kb)];
(* {mean, {centred sum of squares, k}, constant} *)
scaledMoments[x_List] := With[{k = scaleExponent[x]}, With[{mo = moments[pow2[x, -k]]},
  {restore[mo[[1]], k], {mo[[2]], k}, mo[[3]]}]];
(* x scaled to max |x| in [0.5, 1): for ratios that do not depend on the scale (correlations) *)
unitScaled[x_List] := pow2[x, -scaleExponent[x]];

(* Centred lagged sums: over segments, Sum (x[k] - xbar) (y[k - lag] - ybar), lag = 0..maxLag,
   never across a segment break, with the means of the whole series.
   Mathics3 evaluates each product of a listable Times on its own (about 0.3 ms), so the direct
   sums would cost (maxLag + 1) N evaluations: 100000 for N = 2000 to lag 50. They come instead
   from one product of two exact integers (Kronecker substitution): each series is scaled by a
   power of two to integers X below 2^62 (exact to 2^-62 of its largest value, finer than the
   doubles' own rounding of that value), written as the base-16^w digits of one integer, y in
   reverse order, and the coefficient of 16^(w (N - 1 + lag)) in the product is the lagged sum of
   X and Y, exactly; maxLag zeros between segments keep the lags from crossing a break. The
   centring is exact too: Sum (X - mx)(Y - my) = Sum X Y - my Sum X - mx Sum Y + count mx my over
   the pairs of each lag, with the sums of the first and last values of each segment. A series
   costs four listable steps over its values (scaling, Floor, offset, IntegerString); the rest is
   integer and string arithmetic over the whole series at once, and lists of maxLag + 1 values. *)
$hexDigits = 40;  (* per coefficient: |sum| < N 2^124 stays below 16^40/2 for N < 2^34 *)
$half = 2^(4 $hexDigits - 1);
ones[k_] := (16^($hexDigits k) - 1)/(16^$hexDigits - 1);  (* 1 + 16^w + ... + 16^(w (k - 1)) *)

segmentsOf[v_List, starts_] := Take[v, #] & /@ transpose[{starts + 1, Append[Rest[starts], Length[v]]}];

(* A series x as {Sum X_i 16^(w i), Sum X_i 16^(w (n - 1 - i)), n, scale, mean, segment sums}, X =
   Floor[x 2^scale] with the gaps, n its length with them; per segment {total, sums of its first
   h values, of its last h values, length}, h = 0..maxLag. *)
packSeries[x_List, maxLag_, starts_] := Module[{ends = extremes[x], top, k, ints, gapped, hex, n, sums},
  top = Max[-First[ends], Last[ends]];
  k = If[top == 0, 0, 62 - Ceiling[Log[2., top]]];
  (* 2^k beyond the doubles (tiny data) is applied in two exact steps *)
  ints = Floor[If[k > 1000, (x 2.^(k - 600)) 2.^600, x 2.^k]];
  gapped = If[Length[starts] > 1, Join @@ Riffle[segmentsOf[ints, starts], {ConstantArray[0, maxLag]}], ints];
  n = Length[gapped];
  hex = IntegerString[gapped + $half, 16, $hexDigits];
  sums = Function[seg, With[{t = Total[seg], w = Min[maxLag, Length[seg]]},
    {t, PadRight[Prepend[accumulate[Take[seg, w]], 0], maxLag + 1, t],
     PadRight[Prepend[accumulate[Reverse[Take[seg, -w]]], 0], maxLag + 1, t], Length[seg]}]] /@ segmentsOf[ints, starts];
  {ToExpression["16^^" <> StringJoin[Reverse[hex]]] - $half ones[n],
   ToExpression["16^^" <> StringJoin[hex]] - $half ones[n], n, k, Total[ints]/Length[ints], sums}];

packedSums[{px_, _, n_, kx_, mx_, sx_}, {_, qy_, _, ky_, my_, sy_}, maxLag_] := Module[{text, chunks, raw, lag = Range[0, maxLag]},
  text = IntegerString[px qy + $half ones[2 n - 1], 16, $hexDigits (2 n - 1)];
  chunks = StringCases[StringTake[text, {$hexDigits (n - 1 - maxLag) + 1, $hexDigits n}],
    RegularExpression["[0-9a-f]{" <> ToString[$hexDigits] <> "}"]];
  raw = Reverse[ToExpression["{16^^" <> StringRiffle[chunks, ",16^^"] <> "}"]] - $half;
  (* per segment and lag: Sum X[k] over the pairs (all but the first lag values), Sum Y[k - lag]
     (all but the last lag values) and the number of pairs; none once the lag reaches the length *)
  N[(raw + Total[MapThread[Function[{a, b}, UnitStep[a[[4]] - 1 - lag] (
      - my (a[[1]] - Take[a[[2]], maxLag + 1]) - mx (b[[1]] - Take[b[[3]], maxLag + 1]) + mx my (a[[4]] - lag))],
    {sx, sy}]])/2^(kx + ky)]];

laggedSums[x_List, y_List, maxLag_, starts_] := With[{px = packSeries[x, maxLag, starts]},
  packedSums[px, If[x === y, px, packSeries[y, maxLag, starts]], maxLag]];

productCounts[starts_, n_, maxLag_] := With[{lengths = segmentLengths[starts, n]},
  Table[Total[Max[# - lag, 0] & /@ lengths], {lag, 0, maxLag}]];

(* IEEE-style helpers: Mathics turns 1/0. and Log[0.] into ComplexInfinity and Indeterminate. *)
nanQ[x_] := x === Indeterminate;
ieeeMean[values_List] := Which[
  MemberQ[values, Indeterminate], Indeterminate,
  MemberQ[values, DirectedInfinity[-1]] && MemberQ[values, DirectedInfinity[1]], Indeterminate,
  MemberQ[values, DirectedInfinity[-1]], -Infinity,
  MemberQ[values, DirectedInfinity[1]], Infinity,
  True, Total[values]/Length[values]];
nLog[n_, v_] := If[v == 0, -Infinity, n Log[v]];

(* Degenerate values of contract 3.2 for the fit metrics. *)
degenerate[value_, constant_, exact_] := Which[constant && exact, Indeterminate, constant, -Infinity, True, value];

(* Only what the metric needs: R^2 and fit use the SSE, VAF the centred sum of the residual. *)
fitParts[meas_List, e_List, vafQ_] := Module[{tm = scaledMoments[meas], te = If[vafQ, scaledMoments[e], {0., {0., 0}, False}]},
  <|"sse" -> If[vafQ, {0., 0}, scaledSumSq[e]], "tss" -> tm[[2]], "constant" -> tm[[3]], "ssc_e" -> te[[2]],
    "e_constant" -> te[[3]]|>];

r2Value[p_] := degenerate[If[p["constant"], 0., 1. - ssRatio[p["sse"], p["tss"]]], p["constant"], First[p["sse"]] == 0];
fitValue[p_] := degenerate[If[p["constant"], 0., 100. (1. - Sqrt[ssRatio[p["sse"], p["tss"]]])], p["constant"],
  First[p["sse"]] == 0];
vafValue[p_] := degenerate[If[p["constant"], 0., 100. (1. - ssRatio[p["ssc_e"], p["tss"]])], p["constant"], p["e_constant"]];

fitMetric[function_, valueOf_, meas_, pred_, opts_] := guard @ Module[{a, b, mo, cols, parts, values, live},
  {a, b} = pairData[function, 2, meas, pred];
  cols = prepare[function, 2, {{"tau_meas", a, None}, {"tau_pred", b, None}}, opts["nan_policy"], None, False][[1]];
  mo = checkMultioutput[opts["multioutput"], $multioutputs, function];
  {a, b} = cols;
  If[mo === "pooled", valueOf[fitParts[Flatten[a], Flatten[a - b], function === "vaf"]],
  parts = MapThread[fitParts[#1, #1 - #2, function === "vaf"] &, {a, b}];
  values = valueOf /@ parts;
  Switch[mo,
    "raw_values", values,
    "uniform_average", ieeeMean[values],
    "variance_weighted",
      live = Pick[Range[Length[parts]], Not[#["constant"]] & /@ parts];
      If[live === {}, ieeeMean[values],
        (* the weights TSS_j at the largest live joint's scale: tiny data keep their weights *)
        With[{top = Max[#["tss"][[2]] & /@ parts[[live]]]},
          With[{w = restore[#["tss"][[1]], 2 (#["tss"][[2]] - top)] & /@ parts[[live]]},
            Total[w values[[live]]]/Total[w]]]]]]];

(* Association holds its arguments in Mathics3: build it from an evaluated list of rules. *)
optionValues[opts_, defaults_] := Association @@ Join[defaults, opts];

(* ------------------------------------------------------------------ point metrics *)

residuals[meas_, pred_, opts : OptionsPattern[]] := guard @ Module[{o, a, b, e},
  o = optionValues[{opts}, {"nan_policy" -> "raise"}];
  {a, b} = pairData["residuals", 1, meas, pred];
  {a, b} = prepare["residuals", 1, {{"tau_meas", a, None}, {"tau_pred", b, None}}, o["nan_policy"], None, False][[1]];
  e = a - b;
  If[Length[Dimensions[meas]] === 1 && Length[Dimensions[pred]] === 1, First[e], transpose[e]]];

sse[meas_, pred_, opts : OptionsPattern[]] := guard @ Module[{o, a, b, mo},
  o = optionValues[{opts}, {"multioutput" -> "pooled", "nan_policy" -> "raise"}];
  {a, b} = pairData["sse", 1, meas, pred];
  {a, b} = prepare["sse", 1, {{"tau_meas", a, None}, {"tau_pred", b, None}}, o["nan_policy"], None, False][[1]];
  mo = checkMultioutput[o["multioutput"], {"pooled", "raw_values"}, "sse"];
  If[mo === "pooled", ssValue[scaledSumSq[Flatten[a - b]]], ssValue[scaledSumSq[#]] & /@ (a - b)]];

maxAbsError[meas_, pred_, opts : OptionsPattern[]] := guard @ Module[{o, a, b, mo, e},
  o = optionValues[{opts}, {"multioutput" -> "pooled", "nan_policy" -> "raise"}];
  {a, b} = pairData["max_abs_error", 1, meas, pred];
  {a, b} = prepare["max_abs_error", 1, {{"tau_meas", a, None}, {"tau_pred", b, None}}, o["nan_policy"], None, False][[1]];
  mo = checkMultioutput[o["multioutput"], {"pooled", "raw_values"}, "max_abs_error"];
  e = a - b;
  If[mo === "pooled", Max[Abs[extremes[Flatten[e]]]], Max[Abs[extremes[#]]] & /@ e]];

rmse[meas_, pred_, opts : OptionsPattern[]] := guard @ Module[{o, a, b, mo, conv, n, m, perJoint},
  o = optionValues[{opts}, {"multioutput" -> "pooled", "convention" -> None, "nan_policy" -> "raise"}];
  {a, b} = pairData["rmse", 1, meas, pred];
  {a, b} = prepare["rmse", 1, {{"tau_meas", a, None}, {"tau_pred", b, None}}, o["nan_policy"], None, False][[1]];
  mo = checkMultioutput[o["multioutput"], {"pooled", "raw_values", "uniform_average"}, "rmse"];
  conv = checkConvention[o["convention"], mo];
  {m, n} = Dimensions[a];
  If[mo === "pooled", rootMean[scaledSumSq[Flatten[a - b]], If[conv === "per_sample", n, n m]],
    perJoint = rootMean[scaledSumSq[#], n] & /@ (a - b);
    If[mo === "raw_values", perJoint, Total[perJoint]/m]]];

vaf[meas_, pred_, opts : OptionsPattern[]] :=
  fitMetric["vaf", vafValue, meas, pred, optionValues[{opts}, {"multioutput" -> "pooled", "nan_policy" -> "raise"}]];
fitPercent[meas_, pred_, opts : OptionsPattern[]] :=
  fitMetric["fit_percent", fitValue, meas, pred, optionValues[{opts}, {"multioutput" -> "pooled", "nan_policy" -> "raise"}]];
r2[meas_, pred_, opts : OptionsPattern[]] :=
  fitMetric["r2", r2Value, meas, pred, optionValues[{opts}, {"multioutput" -> "pooled", "nan_policy" -> "raise"}]];

(* ------------------------------------------------------------------ residual statistics *)

residualMean[e_, opts : OptionsPattern[]] := guard @ Module[{o, a},
  o = optionValues[{opts}, {"nan_policy" -> "raise"}];
  a = residualData["residual_mean", 1, e];
  a = prepare["residual_mean", 1, {{"e", a, None}}, o["nan_policy"], None, False][[1, 1]];
  First[moments[#]] & /@ a];

residualVariance[e_, opts : OptionsPattern[]] := guard @ Module[{o, a, n, ddof},
  o = optionValues[{opts}, {"ddof" -> 1, "nan_policy" -> "raise"}];
  a = residualData["residual_variance", 2, e];
  a = prepare["residual_variance", 2, {{"e", a, None}}, o["nan_policy"], None, False][[1, 1]];
  n = Length[First[a]];
  ddof = checkIntRange["ddof", o["ddof"], 0, n, "an integer with 0 <= ddof < N=" <> ToString[n]];
  With[{ss = scaledMoments[#][[2]]}, restore[ss[[1]]/(n - ddof), 2 ss[[2]]]] & /@ a];

(* Two-sided Student t p-value 2 P(T > |t|) for df degrees of freedom (real df allowed). *)
tTwoSided[t_, df_] := Which[
  t === Indeterminate, Indeterminate,
  ! NumberQ[t], 0.,
  True, betaRegularized[df/(df + t^2), df/2., 0.5]];

(* t = mean Sqrt[n]/s with the degenerate values of contract 3.2 for s = 0. *)
tStatistic[mean_, n_, s_] := Which[
  s > 0, mean Sqrt[n]/s,
  mean > 0, Infinity, mean < 0, -Infinity, True, Indeterminate];

zeroMeanTest[e_, opts : OptionsPattern[]] := guard @ Module[
  {o, a, starts, n, limit, k, kUsed, means, stds, rho, weights, total, nEff, tIid, tEff, scaledParts},
  o = optionValues[{opts}, {"segments" -> None, "nan_policy" -> "raise"}];
  a = residualData["zero_mean_test", 2, e];
  {a, starts} = prepare["zero_mean_test", 2, {{"e", a, None}}, o["nan_policy"], o["segments"], True];
  a = First[a]; n = Length[First[a]];
  limit = Max[segmentLengths[starts, n]];
  k = Min[Floor[4. (n/100.)^(2./9.)], n - 1];
  kUsed = Min[k, limit - 1];
  (* the t statistics are ratios: computed on each series scaled by a power of two (contract 1.3) *)
  scaledParts = Function[x, With[{k = scaleExponent[x]}, With[{mo = moments[pow2[x, -k]]},
    {mo[[1]], Sqrt[mo[[2]]/(n - 1)], k}]]] /@ a;
  means = MapThread[restore, {scaledParts[[All, 1]], scaledParts[[All, 3]]}];
  stds = MapThread[restore, {scaledParts[[All, 2]], scaledParts[[All, 3]]}];
  weights = 1. - Range[kUsed]/(k + 1.);
  total = Map[If[kUsed > 0, With[{r = biasedRho[#, kUsed, starts]},
      If[nanQ[First[r]], Indeterminate, weights . Rest[r]]], 0.] &, a];
  nEff = Map[If[nanQ[#] || # <= 0, N[n], Min[Max[n/(1. + 2. #), 2.], N[n]]] &, total];
  tIid = MapThread[tStatistic[#1, n, #2] &, {scaledParts[[All, 1]], scaledParts[[All, 2]]}];
  tEff = MapThread[tStatistic[#1, #3, #2] &, {scaledParts[[All, 1]], scaledParts[[All, 2]], nEff}];
  <|"mean" -> means, "std" -> stds, "n_samples" -> n,
    "statistic_iid" -> tIid, "pvalue_iid" -> (tTwoSided[#, n - 1] & /@ tIid), "df_iid" -> n - 1,
    "statistic_eff" -> tEff, "pvalue_eff" -> MapThread[tTwoSided[#1, #2 - 1.] &, {tEff, nEff}],
    "df_eff" -> nEff - 1., "n_eff" -> nEff, "bandwidth" -> k|>];

(* ------------------------------------------------------------------ autocorrelation *)

(* Biased autocorrelation rho(0..maxLag) of one series (segments respected); Indeterminate when constant. *)
biasedRho[x_List, maxLag_, starts_] := Module[{s},
  If[constantQ[x], ConstantArray[Indeterminate, maxLag + 1],
    s = With[{u = unitScaled[x]}, laggedSums[u, u, maxLag, starts]];
    If[First[s] == 0, ConstantArray[Indeterminate, maxLag + 1], Prepend[Rest[s]/First[s], 1.]]]];

acfColumn[x_List, maxLag_, adjusted_, starts_] := Module[{n = Length[x], s, denominators},
  If[constantQ[x], ConstantArray[Indeterminate, maxLag + 1],
    s = With[{u = unitScaled[x]}, laggedSums[u, u, maxLag, starts]];
    If[First[s] == 0, ConstantArray[Indeterminate, maxLag + 1],
      denominators = If[adjusted, productCounts[starts, n, maxLag], ConstantArray[n, maxLag + 1]];
      Prepend[Rest[(s/denominators)/(First[s]/n)], 1.]]]];

autocorrelation[e_, maxLag_, opts : OptionsPattern[]] := guard @ Module[{o, a, starts, n, limit, lag, adjusted, rho},
  o = optionValues[{opts}, {"adjusted" -> True, "segments" -> None, "nan_policy" -> "raise"}];
  a = residualData["autocorrelation", 2, e];
  {a, starts} = prepare["autocorrelation", 2, {{"e", a, None}}, o["nan_policy"], o["segments"], True];
  a = First[a]; n = Length[First[a]];
  limit = Max[segmentLengths[starts, n]];
  lag = checkIntRange["max_lag", maxLag, 0, limit, "an integer with 0 <= max_lag < " <> ToString[limit]];
  adjusted = checkAdjusted[o["adjusted"]];
  rho = acfColumn[#, lag, adjusted, starts] & /@ a;
  If[Length[Dimensions[e]] === 1, First[rho], transpose[rho]]];

normalQuantile[p_] := Sqrt[2.] InverseErf[2. p - 1.];

confidenceBand[n_, opts : OptionsPattern[]] := guard @ Module[{o, level},
  o = optionValues[{opts}, {"level" -> 0.95}];
  If[! (int64Q[n] && n >= 1), paramFail["n", "an integer with n >= 1", n]];
  level = checkLevel[o["level"]];
  normalQuantile[(1. + level)/2.]/Sqrt[N[n]]];

(* ------------------------------------------------------------------ portmanteau tests *)

(* Below this the survival probability loses digits in the subnormal range or underflows. *)
$logSFSwitch = 1.*^-280;

(* Regularized upper incomplete gamma Q(a, x) and its logarithm, in machine arithmetic: the series
   for P below x < a + 1, the continued fraction (modified Lentz) above, the latter kept in log
   space so that Q far below 1e-308 still has an accurate logarithm. GammaRegularized would say the
   same in Mathematica, but Mathics3 10 leaves it unevaluated for real arguments. *)
logGammaQ[a_, x_] := Which[
  x == 0., 0.,
  x < a + 1., Log[1. - gammaPSeries[a, x]],
  True, gammaQLogCF[a, x]];

gammaPSeries[a_, x_] := Module[{sum = 1./a, term = 1./a, k = 0},
  While[k < 100000 && Abs[term] > Abs[sum] 1.*^-17, k++; term = term x/(a + k); sum += term];
  sum Exp[-x + a Log[x] - LogGamma[a]]];

gammaQLogCF[a_, x_] := Module[{tiny = 1.*^-300, b, c, d, h, an, delta, i = 0},
  b = x + 1. - a; c = 1./tiny; d = 1./b; h = d; delta = 0.;
  While[i < 100000 && Abs[delta - 1.] >= 1.*^-16,
    i++; an = -i (i - a); b += 2.;
    d = an d + b; If[Abs[d] < tiny, d = tiny];
    c = b + an/c; If[Abs[c] < tiny, c = tiny];
    d = 1./d; delta = d c; h *= delta];
  -x + a Log[x] - LogGamma[a] + Log[h]];

chi2LogSF[q_, df_] := Which[
  nanQ[q], Indeterminate,
  ! NumberQ[q], -Infinity,
  q <= 0, 0.,
  IntegerQ[df] && df > 0, chi2LogSFInteger[q/2., df],
  True, logGammaQ[df/2., q/2.]];

chi2SF[q_, df_] := sfFromLog[chi2LogSF[q, df]];
sfFromLog[l_] := Which[nanQ[l], Indeterminate, ! NumberQ[l], 0., l < -708.3964185322641, 0., True, Exp[l]];

(* For whole df (every portmanteau test), Q(df/2, x) is a finite sum, summed here in log space:
   Q = e^-x Sum_{k<a} x^k/k! for a = df/2 whole, and Q = Erfc[Sqrt[x]] + e^-x Sum_{k<a-1/2}
   x^(k+1/2)/Gamma(k+3/2) for a half-integer. A few operations on lists of at most df/2 terms
   instead of the iterations of the series or the continued fraction, each of which costs
   Mathics3 milliseconds. Exact where it matters: all terms are positive. *)
chi2LogSFInteger[x_, df_] := -x + logSumExp[If[EvenQ[df],
  Range[0, df/2 - 1] Log[x] - logGammaTable[2, df/2],
  Append[(Range[0, (df - 3)/2] + 0.5) Log[x] - logGammaTable[3, (df - 1)/2], Log[erfcx[Sqrt[x]]]]]];

(* LogGamma[(first + 2 i)/2] for i = 0 .. count - 1: LogGamma[k + 1] or LogGamma[k + 3/2], remembered. *)
logGammaTable[first_, count_] := logGammaTable[first, count] = LogGamma[(first + 2. Range[0, count - 1])/2.];

logSumExp[t_List] := With[{top = Max[t]}, top + Log[Total[Exp[t - top]]]];

(* e^(z^2) Erfc[z], by its asymptotic series where Erfc itself would underflow. *)
erfcx[z_] := If[z < 25., Exp[z z] Erfc[z],
  With[{u = 1./(2. z z)}, (1. - u (1. - 3. u (1. - 5. u (1. - 7. u (1. - 9. u)))))/(z Sqrt[Pi])]];

(* Regularized incomplete beta I_x(a, b) by its continued fraction (Lentz), with the symmetry
   I_x(a, b) = 1 - I_(1-x)(b, a) where the fraction converges slowly. *)
betaCF[a_, b_, x_] := Module[{tiny = 1.*^-300, c = 1., d, h, m = 0, aa, delta = 0., m2},
  d = 1. - (a + b) x/(a + 1.); If[Abs[d] < tiny, d = tiny]; d = 1./d; h = d;
  While[m < 100000 && Abs[delta - 1.] >= 1.*^-16,
    m++; m2 = 2 m;
    aa = m (b - m) x/((a - 1. + m2) (a + m2));
    d = 1. + aa d; If[Abs[d] < tiny, d = tiny]; c = 1. + aa/c; If[Abs[c] < tiny, c = tiny];
    d = 1./d; h *= d c;
    aa = -(a + m) (a + b + m) x/((a + m2) (a + 1. + m2));
    d = 1. + aa d; If[Abs[d] < tiny, d = tiny]; c = 1. + aa/c; If[Abs[c] < tiny, c = tiny];
    d = 1./d; delta = d c; h *= delta];
  h];

betaRegularized[x_, a_, b_] := Module[{front},
  Which[x <= 0., 0., x >= 1., 1.,
    True,
      front = Exp[LogGamma[a + b] - LogGamma[a] - LogGamma[b] + a Log[x] + b Log[1. - x]];
      If[x < (a + 1.)/(a + b + 2.), front betaCF[a, b, x]/a, 1. - front betaCF[b, a, 1. - x]/b]]];

portmanteau[function_, e_, lags_, opts_] := guard @ Module[
  {o, a, starts, n, limit, lagList, modelDf, hMax, counts, requirement, stats, df, logs},
  o = optionValues[opts, {"model_df" -> 0, "segments" -> None, "nan_policy" -> "raise"}];
  a = residualData[function, 2, e];
  {a, starts} = prepare[function, 2, {{"e", a, None}}, o["nan_policy"], o["segments"], True];
  a = First[a]; n = Length[First[a]];
  limit = Max[segmentLengths[starts, n]];
  requirement = "a positive integer or a non-empty sequence of positive integers less than " <> ToString[limit];
  lagList = Which[int64Q[lags], {lags}, ListQ[lags], lags, True, paramFail["lags", requirement, lags]];
  If[lagList === {} || ! AllTrue[lagList, int64Q[#] && 0 < # < limit &], paramFail["lags", requirement, lags]];
  modelDf = checkIntRange["model_df", o["model_df"], 0, Min[lagList],
    "an integer with 0 <= model_df < " <> ToString[Min[lagList]]];
  hMax = Max[lagList];
  counts = Rest[productCounts[starts, n, hMax]];
  stats = Map[Function[x, Module[{rho = biasedRho[x, hMax, starts], cumulative},
      If[nanQ[First[rho]], ConstantArray[Indeterminate, Length[lagList]],
        cumulative = accumulate[If[function === "ljung_box", n (n + 2.) Rest[rho]^2/counts, n Rest[rho]^2]];
        cumulative[[lagList]]]]], a];
  stats = transpose[stats];
  df = lagList - modelDf;
  logs = MapThread[Function[{row, d}, chi2LogSF[#, d] & /@ row], {stats, df}];
  <|"lags" -> lagList, "statistic" -> stats, "pvalue" -> Map[sfFromLog, logs, {2}], "log_pvalue" -> logs, "df" -> df|>];

ljungBox[e_, lags_, opts : OptionsPattern[]] := portmanteau["ljung_box", e, lags, {opts}];
boxPierce[e_, lags_, opts : OptionsPattern[]] := portmanteau["box_pierce", e, lags, {opts}];

(* ------------------------------------------------------------------ cross-correlation *)

crossCorrelation[e_, regressor_, maxLag_, opts : OptionsPattern[]] := guard @ Module[
  {o, a, yDims, n, m, p, yCols, starts, limit, lag, adjusted, level, nJoints, ePacked, rho, mask, data},
  o = optionValues[{opts}, {"n_joints" -> None, "adjusted" -> True, "level" -> 0.95, "segments" -> None, "nan_policy" -> "raise"}];
  checkType[e, "e"];
  yDims = checkType[regressor, "regressor"];
  a = checkSignal[e, "e"];
  {m, n} = {Length[a], Length[First[a]]};
  nJoints = o["n_joints"];
  p = Which[
    Length[yDims] == 3,
      If[yDims[[3]] == 0, fail["InvalidShape", "regressor must have at least one column, got shape " <> shapeString[yDims]]];
      If[yDims[[1]] != n || yDims[[2]] != m,
        fail["ShapeMismatch", "regressor must have shape (N, m, p) = (" <> ToString[n] <> ", " <> ToString[m] <>
          ", p) to match e, got " <> shapeString[yDims]]];
      yDims[[3]],
    Length[yDims] == 2 && nJoints =!= None,
      If[yDims[[2]] == 0, fail["InvalidShape", "regressor must have at least one column, got shape " <> shapeString[yDims]]];
      If[yDims[[1]] != n m, fail["ShapeMismatch", "regressor has " <> ToString[yDims[[1]]] <> " rows, which is not N*m = " <>
          ToString[n] <> "*" <> ToString[m]]];
      yDims[[2]],
    True, fail["InvalidShape", "regressor must be 3-D (N, m, p) or 2-D (N*m, p) with n_joints, got shape " <> shapeString[yDims]]];
  checkMinSamples["cross_correlation", n, 2];
  (* the (N, m*p) view: column j*p + c is joint j, column c, for both accepted forms *)
  yCols = transpose[Partition[Flatten[regressor], m p]];
  {data, starts} = prepare["cross_correlation", 2, {{"e", a, None}, {"regressor", yCols, p}}, o["nan_policy"], o["segments"], True];
  {a, yCols} = data; n = Length[First[a]];
  limit = Max[segmentLengths[starts, n]];
  lag = checkIntRange["max_lag", maxLag, 0, limit, "an integer with 0 <= max_lag < " <> ToString[limit]];
  If[Length[yDims] == 3,
    If[nJoints =!= None && ! (int64Q[nJoints] && nJoints > 0 && nJoints == m),
      If[int64Q[nJoints] && nJoints > 0,
        paramFail["n_joints", "equal to the number of joints of e (m=" <> ToString[m] <> ")", nJoints],
        paramFail["n_joints", "a positive integer dividing the regressor rows", nJoints]]],
    If[! (int64Q[nJoints] && nJoints > 0 && Mod[yDims[[1]], nJoints] == 0),
      paramFail["n_joints", "a positive integer dividing the regressor rows", nJoints]];
    If[nJoints != m, paramFail["n_joints", "equal to the number of joints of e (m=" <> ToString[m] <> ")", nJoints]]];
  adjusted = checkAdjusted[o["adjusted"]];
  level = checkLevel[o["level"]];
  mask = Partition[constantQ /@ yCols, p];
  (* each series is centred and packed once, then paired with every series it meets *)
  ePacked = If[constantQ[#], None, packSeries[unitScaled[#], lag, starts]] & /@ a;
  rho = MapThread[crossColumn[#1, #2, lag, adjusted, starts, n] &,
    {Join @@ (ConstantArray[#, p] & /@ ePacked), yCols}];
  <|"rho" -> Partition[rho, p], "constant_mask" -> mask, "band" -> normalQuantile[(1. + level)/2.]/Sqrt[N[n]]|>];

(* rho(0..maxLag) of one joint's residual (packed, None when constant) and one regressor column. *)
crossColumn[ex_, y_List, maxLag_, adjusted_, starts_, n_] := Module[{py, sx, sy, s, den},
  If[ex === None || constantQ[y], ConstantArray[Indeterminate, maxLag + 1],
    py = packSeries[unitScaled[y], maxLag, starts];
    sx = First[packedSums[ex, ex, 0]]; sy = First[packedSums[py, py, 0]];
    If[sx == 0 || sy == 0, ConstantArray[Indeterminate, maxLag + 1],
      s = packedSums[ex, py, maxLag];
      den = If[adjusted, productCounts[starts, n, maxLag], ConstantArray[n, maxLag + 1]];
      (s/den)/Sqrt[(sx/n) (sy/n)]]]];

(* ------------------------------------------------------------------ information criteria *)

$maxLog = Log[$MaxMachineNumber];
safeExp[x_] := If[x > $maxLog, Infinity, Exp[x]];

assemble[fitTerm_, nVec_, n_, p_, size_] := Module[{aicV, bicV, aiccV, fpeV, naicV},
  aicV = If[NumberQ[fitTerm], fitTerm + 2 p, fitTerm];
  bicV = If[NumberQ[fitTerm], fitTerm + p Log[N[n]], fitTerm];
  aiccV = Which[p >= n - 1, Indeterminate, NumberQ[aicV], aicV + 2. p (p + 1)/(n - p - 1), True, aicV];
  fpeV = Which[p >= n - 1, Indeterminate, NumberQ[size], size (1 + p/N[n])/(1 - p/N[n]), True, size];
  naicV = If[NumberQ[fitTerm], fitTerm/nVec + 2. p/n, fitTerm];
  {"aic" -> aicV, "bic" -> bicV, "aicc" -> aiccV, "fpe" -> fpeV, "naic" -> naicV}];

informationCriteria[rss_, nObs_, nParams_] := guard @ Module[{n, p, variance},
  If[! (realQ[rss] && NumberQ[rss] && rss >= 0), paramFail["rss", "a finite number >= 0", rss]];
  If[! (int64Q[nObs] && nObs >= 1), paramFail["n_obs", "an integer with n_obs >= 1", nObs]];
  n = nObs;
  p = checkNParams[nParams];
  If[! (p < n - 1), paramFail["n_params", "less than n_obs - 1 = " <> ToString[n - 1], nParams]];
  variance = N[rss]/n;
  Association @@ assemble[nLog[n, variance], n, n, p, variance]];

(* ln det of an m x m residual covariance for the "full" noise model, or -Infinity when it is
   numerically singular: lambda_min <= m eps lambda_max (contract 3.2), in memory and streamed. *)
logDetFull[sigma_, m_] := Module[{eig = Sort[Re[Eigenvalues[sigma]]]},
  If[Last[eig] <= 0. || First[eig] <= m $MachineEpsilon Last[eig], -Infinity, Total[Log[eig]]]];

(* {F, n, N_vec, S} of contract 3.7 for joint-major residual columns. *)
fitTerm[e_, noiseModel_] := Module[{m = Length[e], n = Length[First[e]], ss, sums, logSize, k, es, sigma},
  Switch[noiseModel,
    "pooled",
      ss = scaledSumSq[Flatten[e]];
      If[First[ss] == 0, {-Infinity, n m, n m, 0.},
        {n m logMean[ss, n m], n m, n m, restore[First[ss]/(n m), 2 Last[ss]]}],
    "per_joint",
      sums = scaledSumSq /@ e;
      If[Min[sums[[All, 1]]] == 0, {-Infinity, n, n, 0.},
        logSize = Total[logMean[#, n] & /@ sums];
        {n logSize, n, n, safeExp[logSize]}],
    "full",
      (* one power of two for every joint: eigenvalue ratios stay, ln det gains 2 k m ln 2 *)
      k = scaleExponent[e];
      es = pow2[e, -k];
      sigma = Table[Total[es[[i]] es[[j]]]/n, {i, m}, {j, m}];
      logSize = logDetFull[sigma, m];
      If[logSize === -Infinity, {-Infinity, n, n, 0.},
        logSize = logSize + 2 k m Log[2.];
        {n logSize, n, n, safeExp[logSize]}]]];

criteriaAll[function_, meas_, pred_, opts_] := Module[{o, a, b, p, model, f, n, nVec, size, out},
  o = optionValues[opts, {"n_params" -> Missing[], "noise_model" -> "pooled", "nan_policy" -> "raise"}];
  {a, b} = pairData[function, 2, meas, pred];
  {a, b} = prepare[function, 2, {{"tau_meas", a, None}, {"tau_pred", b, None}}, o["nan_policy"], None, False][[1]];
  p = checkNParams[o["n_params"]];
  model = choice["noise_model", o["noise_model"], {"pooled", "per_joint", "full"}];
  {f, nVec, n, size} = fitTerm[a - b, model];
  out = assemble[f, nVec, n, p, size];
  Association @@ Append[out, "n_obs" -> n]];

criteria[meas_, pred_, opts : OptionsPattern[]] := guard @ criteriaAll["criteria", meas, pred, {opts}];
aic[meas_, pred_, opts : OptionsPattern[]] := guard @ Module[{r = criteriaAll["aic", meas, pred, {opts}]}, r["aic"]];
bic[meas_, pred_, opts : OptionsPattern[]] := guard @ Module[{r = criteriaAll["bic", meas, pred, {opts}]}, r["bic"]];

(* ------------------------------------------------------------------ the lesson's entry points, fixed *)

(* The lesson's validateDynamicsModel (scalar joint data), with its four faults fixed:
   Association[...] instead of <<Association[ (Get), Variance without the WorkingPrecision option,
   Return[$Failed] instead of the two-argument Return that Mathics ignores, and an exact fit giving
   AIC = BIC = -Infinity instead of n Log[0.] (Indeterminate under Mathics). *)
validateDynamicsModel[tauMeas_List, tauPred_List, pParams_Integer] := Module[
  {e, n, rmseV, y, yMean, varY, varE, vafV, num, den, fit, tss, rss, r2V, sigma2Hat, aicV, bicV},
  n = Length[tauMeas];
  If[n != Length[tauPred], Return[$Failed]];
  e = tauMeas - tauPred;
  rmseV = Sqrt[Mean[e^2]];
  y = tauMeas;
  yMean = Mean[y];
  varY = Variance[y];
  varE = Variance[e];
  vafV = 100.0 (1.0 - varE/varY);
  num = Norm[tauMeas - tauPred];
  den = Norm[tauMeas - ConstantArray[yMean, n]];
  fit = 100.0 (1.0 - num/den);
  tss = Total[(y - yMean)^2];
  rss = Total[e^2];
  r2V = 1.0 - rss/tss;
  sigma2Hat = Mean[e^2];
  aicV = If[sigma2Hat == 0, -Infinity, 2.0 pParams + n Log[sigma2Hat]];
  bicV = If[sigma2Hat == 0, -Infinity, pParams Log[n] + n Log[sigma2Hat]];
  Association[
    "RMSE" -> rmseV, "VAF" -> vafV, "FitPercent" -> fit,
    "R2" -> r2V, "AIC" -> aicV, "BIC" -> bicV]];

(* The lesson's residualAutocorrelation, unchanged in substance (it ran as written). *)
residualAutocorrelation[e_List, L_Integer] := Module[{n, e0, r0},
  n = Length[e];
  e0 = e - Mean[e];
  r0 = Total[e0^2]/n;
  Table[If[l == 0, 1.0, Total[Take[e0, {l + 1, n}] Take[e0, {1, n - l}]]/((n - l) r0)], {l, 0, L}]];

End[];
EndPackage[];

(* The streaming accumulator (contract 4.1) and the protocol operation accumulate, in Stream.wl
   next to this file. *)
Get[FileNameJoin[{DirectoryName[$InputFileName], "Stream.wl"}]];
