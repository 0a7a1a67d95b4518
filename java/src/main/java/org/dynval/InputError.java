package org.dynval;

/**
 * Rejected input. Every instance carries one of the contract's kinds and the contract's exact
 * message text, so that callers (and the conformance protocol) can tell the cases apart.
 */
public class InputError extends IllegalArgumentException {
    private static final long serialVersionUID = 1L;

    private final ErrorKind kind;

    public InputError(ErrorKind kind, String message) {
        super(message);
        this.kind = kind;
    }

    public ErrorKind kind() {
        return kind;
    }
}
