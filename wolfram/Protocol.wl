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

(* A whole array at once, with no arithmetic per value: Mathics3 evaluates every element of a
   listable operation on its own (0.2-0.5 ms each), while a string or list operation over the whole
   line is one step. float.hex writes every finite double as [-]0x<d>.<13 hex digits>p<exponent>
   (zero as 0x0.0p+0), so after "0x" -> "2^^" a line is a list of base-2 literals of the language
   once the 13 hex digits of each fraction are written as 52 binary digits. Those come from one
   integer: the hex digits of all values joined, read as one base-16 number and written in base 2.
   The reader then turns each "2^^d.bbb`*^e" into the double it denotes, exactly, and the braces
   put between the values give the array its shape, all in one ToExpression. A line with nan, inf
   or -inf, decimal tokens ("d.ddd`*^e", rounded once by the reader) and anything else are read
   as a flat list (token by token where needed) and then reshaped. *)
hexLineRegex = RegularExpression["-?2\\^\\^[01]\\.[0-9a-f]{13}p[+-]\\d+( -?2\\^\\^[01]\\.[0-9a-f]{13}p[+-]\\d+)*"];
decimalLineRegex = RegularExpression["[+-]?\\d+\\.\\d*e[+-]?\\d+( [+-]?\\d+\\.\\d*e[+-]?\\d+)*"];

(* What follows each value of an array of shape {d1, d2, ...} within one block of d2 d3 ... values:
   "," inside a row, "},{" after a row, "}},{{" after a matrix, ... (remembered per shape). *)
valueSeparators[{}] = {","};
valueSeparators[{d_, rest___}] := valueSeparators[{d, rest}] = With[{inner = valueSeparators[{rest}]},
  Join[Flatten[ConstantArray[inner, d - 1]], Most[inner], {"}" <> Last[inner] <> "{"}]];
pieceSeparators[rest_List] := pieceSeparators[rest] = Flatten[{"^^", ".", "`*^", #} & /@ valueSeparators[rest]];

readHexLine[text_String, dims_List] := Module[{pieces, bits, braces = Length[dims]},
  pieces = StringSplit[text, {" ", "^^", ".", "p"}];
  bits = StringDrop[IntegerString[ToExpression["16^^1" <> StringJoin[pieces[[3 ;; ;; 4]]]], 2], 1];
  pieces[[3 ;; ;; 4]] = StringCases[bits, RegularExpression["[01]{52}"]];
  (* Riffle cycles through the separators; when there are as many as pieces it also appends the last *)
  pieces = Riffle[pieces, pieceSeparators[Rest[dims]]];
  ToExpression[StringJoin[ConstantArray["{", braces], If[EvenQ[Length[pieces]], Most[pieces], pieces],
    ConstantArray["}", braces]]]];

(* Tokens joined by blanks (for one token Mathics3's Riffle would also append the separator). *)
joinTokens[tokens_List] := If[Length[tokens] === 1, First[tokens], StringJoin[Riffle[tokens, " "]]];

(* The values of a flat list of tokens. *)
readReals[tokens_List] := Module[{n = Length[tokens], special, plain, text, hexText, values},
  (* nan, inf and -inf (the only tokens without a digit point) are read on their own. Mathics3 ends
     the process on a Part assignment to a list of positions, so ReplacePart puts them in place. *)
  special = Position[StringFreeQ[tokens, "."], True];
  plain = If[special === {}, tokens, ReplacePart[tokens, special -> "0x0.0p+0"]];
  text = joinTokens[plain];
  hexText = StringReplace[text, {"0x" -> "2^^", ".0p" -> ".0000000000000p"}];
  values = Which[
    n === 0, {},
    StringMatchQ[hexText, hexLineRegex], readHexLine[hexText, {n}],
    StringMatchQ[text, decimalLineRegex], ToExpression["{" <> StringReplace[text, {"e" -> "`*^", " " -> ","}] <> "}"],
    True, readReal /@ plain];
  If[special === {}, values, ReplacePart[values, Thread[special -> (readReal /@ Extract[tokens, special])]]]];

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
  ! FreeQ[dims, 0], ConstantArray[0., dims],
  Length[dims] === 1, flat,
  True, Fold[Partition, flat, Reverse[Rest[dims]]]];

readArray[tokens_List] := Module[{nd = ToExpression[tokens[[2]]], dims, values, hexText},
  dims = ToExpression /@ tokens[[3 ;; 2 + nd]];
  values = tokens[[3 + nd ;;]];
  Which[
    tokens[[1]] =!= "real", reshape[N[readValue /@ values], dims],
    (* the usual line: finite hexadecimal floats only, read straight into their shape *)
    dims =!= {} && FreeQ[dims, 0] && (hexText = StringReplace[joinTokens[values],
      {"0x" -> "2^^", ".0p" -> ".0000000000000p"}]; StringMatchQ[hexText, hexLineRegex]),
      readHexLine[hexText, dims],
    True, reshape[readReals[values], dims]]];

(* ------------------------------------------------------------------ answers *)

dims[x_] := If[ListQ[x], Dimensions[x], {}];

(* A whole list at once, exactly. All finite values are scaled by one power of two 2^k, chosen
   so that every nonzero |x| 2^k is an integer (k = 53 - the smallest binary exponent) and the
   largest stays a double: the scaling is then exact, Floor reads each integer M, and x is written
   as the C99 hexadecimal float "0x<M in hex>p-<k>" (float.fromhex and strtod read it). That is
   five listable steps over the list (Abs, Times, Floor, Sign, IntegerString); Mathics3 has no
   faster way to reach the bits of a double. When the values span more binary exponents than a
   double can hold in one scaling, and for the non-real values (nan, inf, integers, booleans),
   writeReal writes them one at a time. *)
writeReals[{}] = {};
writeReals[values_List] := Module[{special, x, a, nonzero, k, m, scale, text},
  special = Position[values, Except[_Real], {1}, Heads -> False];
  x = ReplacePart[values, special -> 0.];
  a = Abs[x];
  nonzero = DeleteCases[a, 0.];
  k = If[nonzero === {}, 0, 53 - Floor[Log[2., Min[nonzero]]]];
  text = If[nonzero =!= {} && Floor[Log[2., Max[nonzero]]] + k > 1020,
    writeReal /@ x,
    (* 2^k itself may be beyond the doubles: two exact steps then *)
    m = Floor[If[k > 1000, (x 2.^(k - 600)) 2.^600, x 2.^k]];
    scale = If[k >= 0, "p-", "p+"] <> ToString[Abs[k]];
    (* one string for the whole list, split again: no string operation per value (StringTrim: for
       one value Mathics3's Riffle also appends the separator) *)
    StringSplit[StringReplace[StringTrim[StringJoin[Riffle[Riffle[Replace[Sign[m], {-1 -> "-0x", _ -> "0x"}, {1}],
      IntegerString[m, 16]], {"", " "}]]], " " -> scale <> " "] <> scale]];
  If[special === {}, text, ReplacePart[text, Thread[special -> (writeReal /@ Extract[values, special])]]]];

resultLine[name_, value_] := Module[{flat = If[ListQ[value], Flatten[value], {value}], d = dims[value]},
  (* StringRiffle converts every piece with ToString, slowly; the pieces are strings already *)
  StringJoin[Riffle[Join[{"result", name, "real", ToString[Length[d]]}, ToString /@ d, writeReals[flat]], " "]]];

errorLines[DynVal`DynValError[kind_, message_]] := {"error " <> kind <> " " <> StringReplace[message, "\n" -> " "], "end"};

$fields = <|
  "zero_mean_test" -> {"mean", "std", "n_samples", "statistic_iid", "pvalue_iid", "df_iid",
    "statistic_eff", "pvalue_eff", "df_eff", "n_eff", "bandwidth"},
  "ljung_box" -> {"lags", "statistic", "pvalue", "log_pvalue", "df"},
  "box_pierce" -> {"lags", "statistic", "pvalue", "log_pvalue", "df"},
  "cross_correlation" -> {"rho", "constant_mask", "band"},
  "information_criteria" -> {"aic", "bic", "aicc", "fpe", "naic"},
  "criteria" -> {"aic", "bic", "aicc", "fpe", "naic", "n_obs"},
  "accumulate" -> {"sse", "rmse", "max_abs_error", "vaf", "fit_percent", "r2", "residual_mean", "residual_variance",
    "autocorrelation", "rho", "aic", "bic", "aicc", "fpe", "naic"}|>;

$operations = {"residuals", "sse", "rmse", "max_abs_error", "vaf", "fit_percent", "r2", "residual_mean",
  "residual_variance", "zero_mean_test", "autocorrelation", "confidence_band", "ljung_box", "box_pierce",
  "cross_correlation", "information_criteria", "criteria", "aic", "bic", "accumulate"};

(* A value of an Association, or a default: Mathics3 has no Lookup or KeyExistsQ, and
   MemberQ[Keys[a], k] costs some milliseconds there. *)
valueOr[a_, key_, default_] := With[{v = a[key]}, If[Head[v] === Missing, default, v]];
in[inputs_, name_] := valueOr[inputs, name, None];

(* Every case sends all the conventions of its operation (golden/PROTOCOL.md), so they go to DynVal
   as they are, as options; a key a function does not know is ignored. The inputs are held by a
   local variable: Mathics3 copies an argument into every place of the body where its pattern
   variable appears (some forty here), and walks every copy, which for an array costs seconds. *)
compute[op_, c_, inputs_] := Module[{i = inputs, o = Sequence @@ Normal[c]}, Switch[op,
  "residuals", DynVal`residuals[in[i, "tau_meas"], in[i, "tau_pred"], o],
  "sse", DynVal`sse[in[i, "tau_meas"], in[i, "tau_pred"], o],
  "rmse", DynVal`rmse[in[i, "tau_meas"], in[i, "tau_pred"], o],
  "max_abs_error", DynVal`maxAbsError[in[i, "tau_meas"], in[i, "tau_pred"], o],
  "vaf", DynVal`vaf[in[i, "tau_meas"], in[i, "tau_pred"], o],
  "fit_percent", DynVal`fitPercent[in[i, "tau_meas"], in[i, "tau_pred"], o],
  "r2", DynVal`r2[in[i, "tau_meas"], in[i, "tau_pred"], o],
  "residual_mean", DynVal`residualMean[in[i, "e"], o],
  "residual_variance", DynVal`residualVariance[in[i, "e"], o],
  "zero_mean_test", DynVal`zeroMeanTest[in[i, "e"], o],
  "autocorrelation", DynVal`autocorrelation[in[i, "e"], in[i, "max_lag"], o],
  "confidence_band", DynVal`confidenceBand[in[i, "n"], o],
  "ljung_box", DynVal`ljungBox[in[i, "e"], in[i, "lags"], o],
  "box_pierce", DynVal`boxPierce[in[i, "e"], in[i, "lags"], o],
  "cross_correlation", DynVal`crossCorrelation[in[i, "e"], in[i, "regressor"], in[i, "max_lag"], o,
    Sequence @@ If[Head[i["n_joints"]] === Missing, {}, {"n_joints" -> i["n_joints"]}]],
  "information_criteria", DynVal`informationCriteria[in[i, "rss"], in[i, "n_obs"], in[i, "n_params"]],
  "criteria", DynVal`criteria[in[i, "tau_meas"], in[i, "tau_pred"], "n_params" -> in[i, "n_params"], o],
  "aic", DynVal`aic[in[i, "tau_meas"], in[i, "tau_pred"], "n_params" -> in[i, "n_params"], o],
  "bic", DynVal`bic[in[i, "tau_meas"], in[i, "tau_pred"], "n_params" -> in[i, "n_params"], o],
  "accumulate", DynVal`streamAccumulate[in[i, "tau_meas"], in[i, "tau_pred"], in[i, "regressor"], in[i, "n_params"],
    in[i, "max_lag"], o],
  _, DynVal`DynValError["InternalError", "unknown operation " <> op]]];

answerCase[op_, conventions_, inputs_] := Module[{out = compute[op, conventions, inputs], fields = valueOr[$fields, op, None]},
  Which[
    Head[out] === DynVal`DynValError, errorLines[out],
    fields === None, {resultLine["value", out], "end"},
    True, Append[resultLine[#, out[#]] & /@ Select[fields, Head[out[#]] =!= Missing &], "end"]]];

(* ------------------------------------------------------------------ the session *)

$stdin := First[Streams["stdin"]];
$stdout := First[Streams["stdout"]];

emit[lines_List] := WriteString[$stdout, StringRiffle[lines, "\n"] <> "\n"];

readConventions[tokens_List] := Association @@ (Map[
  With[{kv = StringSplit[#, "="]}, kv[[1]] -> readValue[kv[[2]]]] &, tokens]);

(* Mathics3 10 counts every evaluation of a variable that holds a list or an association towards
   $IterationLimit (4096) for the whole of one top-level evaluation and never resets the count; at
   the limit it aborts the evaluation. serve[] is one evaluation for the whole session, so the port
   stopped (exit status 0, no message: the answer is Quiet) after some dozens of cases. The limit
   is meant for one expression rewritten without end; a session needs it lifted. (Mathics3 does not
   accept Infinity here; Mathematica does not count this way.) *)
serve[] := Block[{$IterationLimit = 2^63 - 1}, serveLoop[]];

serveLoop[] := Module[{in = $stdin, line, tokens, op = None, conventions = <||>, inputs = {}, lines},
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
