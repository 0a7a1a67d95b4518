package org.dynval;

import java.io.BufferedReader;
import java.io.IOException;
import java.io.InputStreamReader;
import java.io.OutputStreamWriter;
import java.io.PrintWriter;
import java.io.Writer;
import java.math.BigInteger;
import java.nio.charset.StandardCharsets;
import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import java.util.regex.Pattern;

/**
 * The Java port as a program speaking dynval's conformance protocol (golden/PROTOCOL.md) on
 * standard input and output, so that {@code dynval conform -- java/run-port} can judge it.
 * One JVM serves the whole corpus.
 */
public final class PortMain {
    private PortMain() {
    }

    static final String VERSION = "0.1.0";
    private static final Pattern INTEGER = Pattern.compile("[+-]?[0-9]+");
    private static final Pattern NAME = Pattern.compile("[A-Za-z_][A-Za-z0-9_]*");

    /** A line the protocol does not allow: the session cannot continue. */
    static final class ProtocolError extends Exception {
        private static final long serialVersionUID = 1L;

        ProtocolError(String message) {
            super(message);
        }
    }

    public static void main(String[] args) throws IOException {
        BufferedReader in = new BufferedReader(new InputStreamReader(System.in, StandardCharsets.US_ASCII));
        PrintWriter out = new PrintWriter(new OutputStreamWriter(System.out, StandardCharsets.US_ASCII), false);
        int status = serve(in, out);
        out.flush();
        System.exit(status);
    }

    /** Greet, declare every operation, then answer cases until {@code quit} or end of input. */
    static int serve(BufferedReader in, Writer writer) throws IOException {
        PrintWriter out = writer instanceof PrintWriter ? (PrintWriter) writer : new PrintWriter(writer);
        out.print("dynval-port 1 dynval-java " + VERSION + " (Java " + System.getProperty("java.version") + ")\n");
        for (String op : Operations.OPERATIONS) {
            out.print("capability " + op + "\n");
        }
        out.print("ready\n");
        out.flush();

        String line;
        String[] head = null;
        Map<String, Object> inputs = null;
        while ((line = in.readLine()) != null) {
            String trimmed = line.strip();
            if (trimmed.isEmpty() || trimmed.startsWith("#")) {
                continue;
            }
            String[] tokens = trimmed.split("[ \t]+");
            try {
                if (head == null) {
                    if (tokens[0].equals("quit")) {
                        return 0;
                    }
                    if (!tokens[0].equals("case") || tokens.length < 4) {
                        throw new ProtocolError("expected 'case FAMILY TCID OPERATION ...', got " + abbreviate(line));
                    }
                    head = tokens;
                    inputs = new LinkedHashMap<>();
                    continue;
                }
                switch (tokens[0]) {
                    case "array":
                        readArray(tokens, inputs);
                        break;
                    case "scalar":
                        if (tokens.length != 3) {
                            throw new ProtocolError("expected 'scalar NAME VALUE', got " + abbreviate(line));
                        }
                        inputs.put(checkName(tokens[1]), parseValue(tokens[2]));
                        break;
                    case "end":
                        out.print(answer(head, inputs));
                        out.flush(); // the runner waits for 'end' before it sends the next case
                        head = null;
                        inputs = null;
                        break;
                    default:
                        throw new ProtocolError("expected 'array', 'scalar' or 'end' inside a case, got " + abbreviate(line));
                }
            } catch (ProtocolError error) {
                System.err.println("dynval-java: " + error.getMessage());
                return 3;
            }
        }
        return 0;
    }

    private static String abbreviate(String line) {
        return line.length() > 80 ? line.substring(0, 80) + "..." : line;
    }

    private static String checkName(String name) throws ProtocolError {
        if (!NAME.matcher(name).matches()) {
            throw new ProtocolError("not a name: " + abbreviate(name));
        }
        return name;
    }

    /** The answer lines of one case, {@code end} included. */
    static String answer(String[] head, Map<String, Object> inputs) throws ProtocolError {
        String operation = head[3];
        Map<String, Object> conventions = new LinkedHashMap<>();
        for (int i = 4; i < head.length; i++) {
            int eq = head[i].indexOf('=');
            if (eq <= 0) {
                throw new ProtocolError("expected KEY=VALUE, got " + abbreviate(head[i]));
            }
            conventions.put(checkName(head[i].substring(0, eq)), parseValue(head[i].substring(eq + 1)));
        }
        StringBuilder sb = new StringBuilder();
        try {
            Map<String, Operations.Output> outputs = Operations.run(operation, inputs, conventions);
            for (Map.Entry<String, Operations.Output> entry : outputs.entrySet()) {
                writeOutput(sb, entry.getKey(), entry.getValue());
            }
        } catch (InputError error) {
            sb.setLength(0);
            sb.append("error ").append(error.kind().contractName()).append(' ').append(oneLine(error.getMessage())).append('\n');
        } catch (RuntimeException error) {
            // Not a contract kind: the runner fails the case and shows the text.
            sb.setLength(0);
            sb.append("error InternalError ").append(oneLine(error.getClass().getSimpleName() + ": " + error.getMessage()))
                    .append('\n');
        }
        sb.append("end\n");
        return sb.toString();
    }

    /** Messages go on one ASCII line. */
    private static String oneLine(String message) {
        StringBuilder sb = new StringBuilder();
        for (char c : String.valueOf(message).toCharArray()) {
            sb.append(c >= 32 && c < 127 ? c : (c == '\n' || c == '\t' ? ' ' : '?'));
        }
        return sb.toString();
    }

    private static void writeOutput(StringBuilder sb, String name, Operations.Output output) {
        String type = output.type() == NdArray.Type.INT ? "int" : output.type() == NdArray.Type.BOOL ? "bool" : "real";
        sb.append("result ").append(name).append(' ').append(type).append(' ').append(output.shape().length);
        for (int d : output.shape()) {
            sb.append(' ').append(d);
        }
        for (double v : output.values()) {
            sb.append(' ');
            if (output.type() == NdArray.Type.REAL || !Double.isFinite(v)) {
                sb.append(ProtocolNumbers.writeReal(v));
            } else {
                sb.append((long) v);
            }
        }
        sb.append('\n');
    }

    private static void readArray(String[] tokens, Map<String, Object> inputs) throws ProtocolError {
        if (tokens.length < 4) {
            throw new ProtocolError("expected 'array NAME TYPE NDIM D1 ... Dn V1 ... Vk'");
        }
        String name = checkName(tokens[1]);
        NdArray.Type type;
        switch (tokens[2]) {
            case "real":
                type = NdArray.Type.REAL;
                break;
            case "int":
                type = NdArray.Type.INT;
                break;
            case "bool":
                type = NdArray.Type.BOOL;
                break;
            default:
                throw new ProtocolError("unknown array type " + abbreviate(tokens[2]));
        }
        int ndim = parseCount(tokens[3]);
        if (tokens.length < 4 + ndim) {
            throw new ProtocolError("array " + name + ": missing dimensions");
        }
        int[] shape = new int[ndim];
        long count = 1;
        for (int i = 0; i < ndim; i++) {
            shape[i] = parseCount(tokens[4 + i]);
            count *= shape[i];
        }
        int first = 4 + ndim;
        if (tokens.length - first != count) {
            throw new ProtocolError("array " + name + ": " + (tokens.length - first) + " values for " + count + " elements");
        }
        double[] values = new double[(int) count];
        for (int i = 0; i < values.length; i++) {
            String t = tokens[first + i];
            if (type == NdArray.Type.BOOL && (t.equals("true") || t.equals("false"))) {
                values[i] = t.equals("true") ? 1.0 : 0.0;
                continue;
            }
            try {
                values[i] = ProtocolNumbers.readReal(t);
            } catch (NumberFormatException error) {
                throw new ProtocolError("array " + name + ": " + error.getMessage());
            }
        }
        inputs.put(name, new NdArray(shape, values, type));
    }

    private static int parseCount(String token) throws ProtocolError {
        try {
            int v = Integer.parseInt(token);
            if (v < 0) {
                throw new NumberFormatException();
            }
            return v;
        } catch (NumberFormatException error) {
            throw new ProtocolError("not a dimension: " + abbreviate(token));
        }
    }

    /**
     * A typed value token: none, true, false, an integer ({@code Long}, or {@code BigInteger} beyond
     * int64 so that the contract's int64 bound can reject it), a number ({@code Double}), a quoted
     * string, or a flat list of these.
     */
    static Object parseValue(String token) throws ProtocolError {
        if (token.startsWith("[")) {
            if (!token.endsWith("]")) {
                throw new ProtocolError("unterminated list " + abbreviate(token));
            }
            String inner = token.substring(1, token.length() - 1);
            List<Object> items = new ArrayList<>();
            if (!inner.isEmpty()) {
                for (String part : inner.split(",", -1)) {
                    items.add(parseScalar(part));
                }
            }
            return items;
        }
        return parseScalar(token);
    }

    private static Object parseScalar(String token) throws ProtocolError {
        switch (token) {
            case "none":
                return null;
            case "true":
                return Boolean.TRUE;
            case "false":
                return Boolean.FALSE;
            default:
                break;
        }
        if (token.startsWith("\"")) {
            if (token.length() < 2 || !token.endsWith("\"")) {
                throw new ProtocolError("unterminated string " + abbreviate(token));
            }
            return decodeString(token.substring(1, token.length() - 1));
        }
        if (INTEGER.matcher(token).matches()) {
            BigInteger big = new BigInteger(token.startsWith("+") ? token.substring(1) : token);
            return big.bitLength() < 64 ? (Object) big.longValue() : big;
        }
        try {
            return ProtocolNumbers.readReal(token);
        } catch (NumberFormatException error) {
            throw new ProtocolError(error.getMessage());
        }
    }

    private static String decodeString(String body) throws ProtocolError {
        byte[] bytes = new byte[body.length()];
        int n = 0;
        for (int i = 0; i < body.length(); i++) {
            char c = body.charAt(i);
            if (c == '%') {
                if (i + 2 >= body.length()) {
                    throw new ProtocolError("bad escape in string " + abbreviate(body));
                }
                try {
                    bytes[n++] = (byte) Integer.parseInt(body.substring(i + 1, i + 3), 16);
                } catch (RuntimeException error) {
                    throw new ProtocolError("bad escape in string " + abbreviate(body));
                }
                i += 2;
            } else {
                bytes[n++] = (byte) c;
            }
        }
        return new String(bytes, 0, n, StandardCharsets.UTF_8);
    }
}
