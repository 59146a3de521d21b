/**
 * The OpenAIR 1.0 client. Only {@code org.openair} is exported; the implementation in
 * {@code org.openair.internal} and the conformance shim in {@code org.openair.shim} are not.
 */
module org.openair {
    requires java.xml;

    exports org.openair;
}
