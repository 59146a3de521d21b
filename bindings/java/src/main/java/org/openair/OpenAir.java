package org.openair;

import org.openair.internal.ModuleImpl;

/**
 * The entry point: {@code try (Module m = OpenAir.connect(Options.builder("Reader").build()))}.
 *
 * <p>Connecting opens the primary connection, asks GET_CAPABILITIES (a legacy server answers
 * UNKNOWN_COMMAND, OA-CAP-2), binds with BIND or BIND_NOLISTEN declaring the extensions the server
 * advertised (OA-SESS-19), listens on the port of BIND_ACCEPT, opens the callback connection with
 * a {@code Receive} frame (OA-SESS-7) and posts {@code Psyclone.Module.Connect.<name>}.
 *
 * <p>Threading: {@link #connect(Options)} may be called from any thread; it blocks until the
 * module is set up. See {@link Module} for the threads a module runs.
 */
public interface OpenAir {

    /** The protocol this library speaks. */
    String PROTOCOL = "OpenAIR/1.0";

    /** The library's version. */
    String VERSION = "0.1.0";

    /**
     * Connect and set a module up.
     *
     * @param options how to connect
     * @return the connected module
     * @throws ConnectionClosedException when the server cannot be reached
     * @throws RequestFailedException when BIND is refused
     * @throws OpenAirException for any other failure while setting up
     */
    static Module connect(Options options) {
        return ModuleImpl.connect(options);
    }
}
