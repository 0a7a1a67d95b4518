(* ::Package:: *)

(* The dynval conformance protocol (golden/PROTOCOL.md) for the DynVal package: reading cases,
   calling DynVal, writing answers. Numbers travel as C99 hexadecimal floats ("encoding hex"),
   which are read and written exactly; decimal input is read exactly as well. *)

BeginPackage["DynValProtocol`", {"DynVal`"}];

readReal::usage = "readReal[token] reads one protocol number (decimal, hexadecimal, nan, inf) as a machine real, Indeterminate or a DirectedInfinity; $Failed when it is not a number.";
writeReal::usage = "writeReal[x] writes a machine real as a C99 hexadecimal float exactly as Python's float.hex does (nan, inf, -inf for the non-finite values).";
readValue::usage = "readValue[token] reads a typed protocol value (none, true, false, integer, number, string, list).";
readArray::usage = "readArray[tokens] reads the type, dimensions and values of an array line (tokens after the name).";
answerCase::usage = "answerCase[operation, conventions, inputs] gives the answer lines of one case.";
serve::usage = "serve[] speaks the protocol on standard input and output until quit or end of input.";
$operations::usage = "The operations the port implements.";

Begin["`Private`"];

(* ------------------------------------------------------------------ numbers *)

(* Applied one after the other: 0 and 1 first, so that no rule meets the digits an earlier one wrote. *)
hexDigitRules = {"0x" -> "x", "0" -> "0000", "1" -> "0001", "2" -> "0010", "3" -> "0011", "4" -> "0100",
  "5" -> "0101", "6" -> "0110", "7" -> "0111", "8" -> "1000", "9" -> "1001", "a" -> "1010", "b" -> "1011",
  "c" -> "1100", "d" -> "1101", "e" -> "1110", "f" -> "1111", "x" -> "2^^"};

decimalRegex = RegularExpression["[+-]?(\\d+(\\.\\d*)?|\\.\\d+)(e[+-]?\\d+)?"];
hexRegex = RegularExpression["[+-]?0x[0-9a-f]+(\\.[0-9a-f]*)?p[+-]?\\d+"];

(* Digits before and after the point ("" when absent). *)
splitPoint[m_String] := Which[
  StringFreeQ[m, "."], {m, ""},
  m === ".", {"0", ""},
  StringTake[m, 1] === ".", {"0", StringDrop[m, 1]},
  StringTake[m, -1] === ".", {StringDrop[m, -1], ""},
  True, StringSplit[m, "."]];

(* The exact value of a decimal token as a rational, then the nearest machine real. *)
readDecimal[t_String] := Module[{sign = 1, body = t, mant, exp = 0, intPart, fracPart, pieces},
  If[StringTake[body, 1] === "-", sign = -1; body = StringDrop[body, 1],
    If[StringTake[body, 1] === "+", body = StringDrop[body, 1]]];
  pieces = StringSplit[body, "e"];
  mant = First[pieces];
  If[Length[pieces] == 2, exp = ToExpression[StringReplace[pieces[[2]], "+" -> ""]]];
  {intPart, fracPart} = splitPoint[mant];
  N[sign FromDigits[intPart <> fracPart] 10^(exp - StringLength[fracPart])]];

(* The exact value of a hexadecimal token: an integer mantissa times a power of two. *)
readHex[t_String] := Module[{sign = 1, body = t, mant, exp, intPart, fracPart, pieces},
  If[StringTake[body, 1] === "-", sign = -1; body = StringDrop[body, 1],
    If[StringTake[body, 1] === "+", body = StringDrop[body, 1]]];
  pieces = StringSplit[StringDrop[body, 2], "p"];
  mant = First[pieces];
  exp = ToExpression[StringReplace[pieces[[2]], "+" -> ""]];
  {intPart, fracPart} = splitPoint[mant];
  N[sign FromDigits[intPart <> fracPart, 16] 2^(exp - 4 StringLength[fracPart])]];

readReal[token_String] := Module[{t = ToLowerCase[token]},
  Which[
    StringMatchQ[t, RegularExpression["[+-]?nan(\\(\\w*\\))?"]], Indeterminate,
    MemberQ[{"inf", "+inf", "infinity", "+infinity"}, t], Infinity,
    MemberQ[{"-inf", "-infinity"}, t], -Infinity,
    StringMatchQ[t, hexRegex], readHex[t],
    StringMatchQ[t, decimalRegex], readDecimal[t],
    True, $Failed]];

(* A whole array at once: the reader of the language turns "d.ddd`*^e" (decimal) and
   "2^^b.bbb`*^e" (binary, from the hexadecimal digits) into the nearest machine real, which is
   exact, in one pass over the line. Tokens outside these forms are read one at a time. *)
readReals[tokens_List] := Module[{joined, parts, mants, exps, bins, text},
  joined = StringRiffle[tokens, " "];
  Which[
    tokens === {}, {},
    StringMatchQ[joined, RegularExpression["[0-9e.+\\- ]*"]] && StringFreeQ[joined, "e" ~~ " "] &&
      StringTake[joined, -1] =!= "e" && AllTrue[tokens, StringContainsQ[#, "e"] &],
      ToExpression["{" <> StringReplace[joined, {"e" -> "`*^", " " -> ","}] <> "}"],
    StringMatchQ[joined, RegularExpression["[0-9a-fxp.+\\- ]*"]] && AllTrue[tokens, StringContainsQ[#, "p"] &],
      parts = StringSplit[joined, {" ", "p"}];
      mants = parts[[1 ;; ;; 2]]; exps = parts[[2 ;; ;; 2]];
      (* one rule per pass: Mathics3 replaces a list of rules far more slowly than one rule *)
      bins = StringSplit[Fold[StringReplace, StringRiffle[mants, " "], hexDigitRules], " "];
      text = Fold[StringReplace, StringRiffle[Riffle[bins, exps], "|"],
        {"|-2^^" -> ",-2^^", "|+2^^" -> ",+2^^", "|2^^" -> ",2^^", "|" -> "`*^"}];
      ToExpression["{" <> text <> "}"],
    True, readReal /@ tokens]];

signOf[x_] := If[x < 0, "-", ""];

(* x = m 2^(e - 52) with m a 53-bit integer, for finite x > 0. Scaling by a power of two is exact
   (in two steps, so that neither factor overflows) and Round then reads the integer. *)
binaryParts[x_] := Module[{e = Floor[Log[2., x]], s = 0, k, k1},
  Do[
    k = 52 - e; k1 = Quotient[k, 2];
    s = Floor[(x 2.^k1) 2.^(k - k1)];
    Which[s >= 2^53, e++, s < 2^52, e--, True, Break[]], {4}];
  {s, e}];

writeReal[x_] := Which[
  x === Indeterminate, "nan",
  x === DirectedInfinity[1], "inf",
  x === DirectedInfinity[-1], "-inf",
  x === True, "1",
  x === False, "0",
  IntegerQ[x], writeReal[N[x]],
  x == 0, "0x0.0p+0",
  True, Module[{m53, exponent, sign = signOf[x]},
    {m53, exponent} = binaryParts[Abs[x]];
    If[exponent >= -1022,
      sign <> "0x1." <> IntegerString[m53 - 2^52, 16, 13] <> "p" <> If[exponent >= 0, "+", "-"] <> ToString[Abs[exponent]],
      sign <> "0x0." <> IntegerString[Quotient[m53, 2^(-1022 - exponent)], 16, 13] <> "p-1022"]]];

(* ------------------------------------------------------------------ typed values *)

decodeString[s_String] := Module[{body = StringTake[s, {2, -2}], pieces},
  If[StringFreeQ[body, "%"], body,
    pieces = StringSplit[body, "%"];
    If[StringTake[body, 1] =!= "%", pieces = Prepend[Rest[pieces], First[pieces]]];
    StringJoin[If[StringTake[body, 1] === "%", "", First[pieces]],
      Map[FromCharacterCode[FromDigits[StringTake[#, 2], 16]] <> StringDrop[#, 2] &,
        If[StringTake[body, 1] === "%", pieces, Rest[pieces]]]]]];

readValue[token_String] := Which[
  token === "none", None,
  token === "true", True,
  token === "false", False,
  StringMatchQ[token, RegularExpression["[+-]?\\d+"]], ToExpression[StringReplace[token, "+" -> ""]],
  StringLength[token] >= 2 && StringTake[token, 1] === "\"", decodeString[token],
  StringLength[token] >= 2 && StringTake[token, 1] === "[",
    If[token === "[]", {}, readValue /@ StringSplit[StringTake[token, {2, -2}], ","]],
  True, readReal[token]];

reshape[flat_, dims_] := Which[
  dims === {}, First[flat],
  MemberQ[dims, 0], ConstantArray[0., dims],
  Length[dims] == 1, flat,
  True, Fold[Partition, flat, Reverse[Rest[dims]]]];

readArray[tokens_List] := Module[{type = tokens[[1]], nd = ToExpression[tokens[[2]]], dims, values},
  dims = ToExpression /@ tokens[[3 ;; 2 + nd]];
  values = tokens[[3 + nd ;;]];
  values = If[type === "real", readReals[values],
    N[readValue /@ values]];
  reshape[values, dims]];

(* ------------------------------------------------------------------ answers *)

dims[x_] := If[ListQ[x], Dimensions[x], {}];

(* A whole list at once, every step one listable operation over the list. Each value x is written
   as an integer mantissa and a binary exponent, x = M 2^E ("0x1999999999999ap-56", a C99
   hexadecimal float without a point). With E = Floor[Log2 |x|] - 53, M = x 2^-E is an integer
   of 53 to 55 bits even where Log rounds across a power of two, so the scaling is exact and
   nothing needs correcting. Non-finite, zero, tiny (subnormal range), integer and boolean values
   are written one at a time by writeReal. *)
writeReals[values_List] := Module[{n = Length[values], special, plain, x, a, e, m, text},
  (* Position matches patterns without evaluating anything per element *)
  special = Union[Cases[Join[Position[values, Except[_Real], {1}], Position[values, 0., {1}]], {k_Integer} /; k >= 1 :> k]];
  plain = Complement[Range[n], special];
  If[plain =!= {} && Min[Abs[values[[plain]]]] < 1.*^-290,
    special = Union[special, Select[plain, Abs[values[[#]]] < 1.*^-290 &]];
    plain = Complement[Range[n], special]];
  text = If[plain === {}, {},
    x = values[[plain]];
    a = Abs[x];
    e = Floor[Log[2., a]] - 53;
    m = Round[a 2.^(-e)];
    MapThread[StringJoin, {
      Sign[x] /. {1 -> "0x", -1 -> "-0x"},
      IntegerString[#, 16] <> "p" & /@ m,
      StringSplit[StringTake[ToString[e], {2, -2}], ", "]}]];
  If[special === {}, text,
    (* the special values go back to their places in ascending order *)
    Module[{out = text}, Do[out = Insert[out, writeReal[values[[k]]], k], {k, special}]; out]]];

resultLine[name_, value_] := Module[{flat = If[ListQ[value], Flatten[value], {value}], d = dims[value]},
  StringRiffle[Join[{"result", name, "real", ToString[Length[d]]}, ToString /@ d, writeReals[flat]], " "]];

errorLines[DynVal`DynValError[kind_, message_]] := {"error " <> kind <> " " <> StringReplace[message, "\n" -> " "], "end"};

$fields = <|
  "zero_mean_test" -> {"mean", "std", "n_samples", "statistic_iid", "pvalue_iid", "df_iid",
    "statistic_eff", "pvalue_eff", "df_eff", "n_eff", "bandwidth"},
  "ljung_box" -> {"lags", "statistic", "pvalue", "log_pvalue", "df"},
  "box_pierce" -> {"lags", "statistic", "pvalue", "log_pvalue", "df"},
  "cross_correlation" -> {"rho", "constant_mask", "band"},
  "information_criteria" -> {"aic", "bic", "aicc", "fpe", "naic"},
  "criteria" -> {"aic", "bic", "aicc", "fpe", "naic", "n_obs"}|>;

$operations = {"residuals", "sse", "rmse", "max_abs_error", "vaf", "fit_percent", "r2", "residual_mean",
  "residual_variance", "zero_mean_test", "autocorrelation", "confidence_band", "ljung_box", "box_pierce",
  "cross_correlation", "information_criteria", "criteria", "aic", "bic"};

(* Conventions as options; a key the case does not send takes DynVal's default. *)
hasKey[a_, k_] := MemberQ[Keys[a], k];
opts[conventions_, keys_] := Map[# -> conventions[#] &, Select[keys, hasKey[conventions, #] &]];

in[inputs_, name_] := If[hasKey[inputs, name], inputs[name], None];

compute[op_, c_, i_] := Switch[op,
  "residuals", DynVal`residuals[in[i, "tau_meas"], in[i, "tau_pred"], Sequence @@ opts[c, {"nan_policy"}]],
  "sse", DynVal`sse[in[i, "tau_meas"], in[i, "tau_pred"], Sequence @@ opts[c, {"multioutput", "nan_policy"}]],
  "rmse", DynVal`rmse[in[i, "tau_meas"], in[i, "tau_pred"], Sequence @@ opts[c, {"multioutput", "convention", "nan_policy"}]],
  "max_abs_error", DynVal`maxAbsError[in[i, "tau_meas"], in[i, "tau_pred"], Sequence @@ opts[c, {"multioutput", "nan_policy"}]],
  "vaf", DynVal`vaf[in[i, "tau_meas"], in[i, "tau_pred"], Sequence @@ opts[c, {"multioutput", "nan_policy"}]],
  "fit_percent", DynVal`fitPercent[in[i, "tau_meas"], in[i, "tau_pred"], Sequence @@ opts[c, {"multioutput", "nan_policy"}]],
  "r2", DynVal`r2[in[i, "tau_meas"], in[i, "tau_pred"], Sequence @@ opts[c, {"multioutput", "nan_policy"}]],
  "residual_mean", DynVal`residualMean[in[i, "e"], Sequence @@ opts[c, {"nan_policy"}]],
  "residual_variance", DynVal`residualVariance[in[i, "e"], Sequence @@ opts[c, {"ddof", "nan_policy"}]],
  "zero_mean_test", DynVal`zeroMeanTest[in[i, "e"], Sequence @@ opts[c, {"segments", "nan_policy"}]],
  "autocorrelation", DynVal`autocorrelation[in[i, "e"], in[i, "max_lag"], Sequence @@ opts[c, {"adjusted", "segments", "nan_policy"}]],
  "confidence_band", DynVal`confidenceBand[in[i, "n"], Sequence @@ opts[c, {"level"}]],
  "ljung_box", DynVal`ljungBox[in[i, "e"], in[i, "lags"], Sequence @@ opts[c, {"model_df", "segments", "nan_policy"}]],
  "box_pierce", DynVal`boxPierce[in[i, "e"], in[i, "lags"], Sequence @@ opts[c, {"model_df", "segments", "nan_policy"}]],
  "cross_correlation", DynVal`crossCorrelation[in[i, "e"], in[i, "regressor"], in[i, "max_lag"],
    Sequence @@ Join[opts[c, {"adjusted", "level", "segments", "nan_policy"}],
      If[hasKey[i, "n_joints"], {"n_joints" -> i["n_joints"]}, {}]]],
  "information_criteria", DynVal`informationCriteria[in[i, "rss"], in[i, "n_obs"], in[i, "n_params"]],
  "criteria", DynVal`criteria[in[i, "tau_meas"], in[i, "tau_pred"], "n_params" -> in[i, "n_params"], Sequence @@ opts[c, {"noise_model", "nan_policy"}]],
  "aic", DynVal`aic[in[i, "tau_meas"], in[i, "tau_pred"], "n_params" -> in[i, "n_params"], Sequence @@ opts[c, {"noise_model", "nan_policy"}]],
  "bic", DynVal`bic[in[i, "tau_meas"], in[i, "tau_pred"], "n_params" -> in[i, "n_params"], Sequence @@ opts[c, {"noise_model", "nan_policy"}]],
  _, DynVal`DynValError["InternalError", "unknown operation " <> op]];

answerCase[op_, conventions_, inputs_] := Module[{out = compute[op, conventions, inputs]},
  Which[
    Head[out] === DynVal`DynValError, errorLines[out],
    hasKey[$fields, op],
      Append[Map[resultLine[#, out[#]] &, Select[$fields[op], hasKey[out, #] &]], "end"],
    True, {resultLine["value", out], "end"}]];

(* ------------------------------------------------------------------ the session *)

$stdin := First[Streams["stdin"]];
$stdout := First[Streams["stdout"]];

emit[lines_List] := WriteString[$stdout, StringRiffle[lines, "\n"] <> "\n"];

readConventions[tokens_List] := Association @@ (Map[
  With[{kv = StringSplit[#, "="]}, kv[[1]] -> readValue[kv[[2]]]] &, tokens]);

serve[] := Module[{in = $stdin, line, tokens, op = None, conventions = <||>, inputs = {}, lines},
  emit[Join[{"dynval-port 1 dynval-wolfram 0.1 (Wolfram Language, " <> $Version <> ")", "encoding hex"},
    ("capability " <> #) & /@ $operations, {"ready"}]];
  While[True,
    line = Read[in, String];
    If[line === EndOfFile, Break[]];
    tokens = StringSplit[line];
    Which[
      tokens === {} || StringTake[First[tokens], 1] === "#", Null,
      First[tokens] === "quit", Break[],
      First[tokens] === "case",
        op = tokens[[4]]; conventions = readConventions[tokens[[5 ;;]]]; inputs = {},
      First[tokens] === "scalar", inputs = Append[inputs, tokens[[2]] -> readValue[tokens[[3]]]],
      First[tokens] === "array", inputs = Append[inputs, tokens[[2]] -> readArray[tokens[[3 ;;]]]],
      First[tokens] === "end",
        (* messages would land on standard output, between the protocol's lines *)
        lines = Quiet[answerCase[op, conventions, Association @@ inputs]];
        emit[lines]]]];

End[];
EndPackage[];
