package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertFalse;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.io.IOException;
import java.io.InputStream;
import java.net.InetAddress;
import java.nio.charset.StandardCharsets;
import java.nio.file.Files;
import java.nio.file.Path;
import java.security.KeyStore;
import java.time.Duration;
import java.util.HexFormat;
import java.util.List;
import java.util.Map;
import java.util.Set;
import java.util.concurrent.ConcurrentHashMap;
import javax.net.ssl.KeyManagerFactory;
import javax.net.ssl.SSLContext;
import javax.net.ssl.TrustManagerFactory;
import org.junit.jupiter.api.AfterEach;
import org.junit.jupiter.api.BeforeEach;
import org.junit.jupiter.api.Test;
import org.junit.jupiter.api.Timeout;
import org.junit.jupiter.api.io.TempDir;
import org.openair.ApiMisuseException;
import org.openair.ConnectionClosedException;
import org.openair.Message;
import org.openair.Module;
import org.openair.OpenAir;
import org.openair.Options;
import org.openair.RequestFailedException;

/** Secure mode in the Java client (spec 14.3): the proof, and where the client sends it. */
@Timeout(20)
class AuthTest {
    static final String SECRET = "jtest-secret-0123456789";
    FakeServer fake;
    Module module;
    final Map<FakeServer.Conn, String> nonces = new ConcurrentHashMap<>();

    @BeforeEach
    void start() throws IOException {
        fake = secure(new FakeServer());
    }

    /** Make `f` play a server in secure mode with SECRET for every name. */
    FakeServer secure(FakeServer f) {
        f.advertised = Set.of("noreply", "pipelining", "usec", "auth");
        f.behaviours.put("AUTH_CHALLENGE", (c, req) -> {
            String nonce = HexFormat.of().formatHex(new byte[32]).replace("00", "0a")
                    .substring(0, 60) + String.format("%04x", nonces.size());
            nonces.put(c, nonce);
            c.send(FakeServer.reply(req, "AUTH_NONCE", nonce));
        });
        f.behaviours.put("AUTH_RESPONSE", (c, req) -> {
            String nonce = nonces.remove(c);
            boolean ok = nonce != null
                    && Auth.proof(SECRET, nonce, req.sender()).equals(req.content().strip());
            c.send(ok ? FakeServer.reply(req, "AUTH_ACCEPT", "")
                    : FakeServer.reply(req, "RECEIVE_ERROR", "AUTH_FAILED: wrong proof"));
        });
        return f;
    }

    @AfterEach
    void stop() throws IOException {
        if (module != null) {
            module.close();
        }
        fake.close();
    }

    Options.Builder options(String secret) {
        return Options.builder("JTest").server("127.0.0.1", fake.port()).listen(false)
                .requestTimeout(Duration.ofSeconds(3)).keepalive(Duration.ZERO)
                .reconnect(false).secret(secret);
    }

    @Test
    void proofMatchesTheSpecExample() {
        String nonce = HexFormat.of().formatHex(new byte[] {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11,
                12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31});
        assertEquals("a07677b31933e5bbc655a3898e4781dccb13af8718b1a4d8a76f76ce308f4904",
                Auth.proof("reader-secret-0123456789", nonce, "Reader"));
    }

    @Test
    void optionsNeverShowTheSecret() {
        Options o = options(SECRET).build();
        assertFalse(o.toString().contains(SECRET));
        assertEquals(SECRET, o.secret().value());
    }

    @Test
    void primaryAndCallbackProveBeforeBindAndReceive() throws Exception {
        module = OpenAir.connect(options(SECRET).build());
        List<String> primary = new java.util.ArrayList<>();
        List<String> callback = new java.util.ArrayList<>();
        FakeServer.Conn first = fake.history.get(0).conn();
        for (FakeServer.Received r : fake.history) {
            String what = r.tag() == Frame.Tag.RECEIVE ? "Receive" : r.message().type();
            (r.conn() == first ? primary : callback).add(what);
        }
        assertEquals(List.of("GET_CAPABILITIES", "AUTH_CHALLENGE", "AUTH_RESPONSE",
                "BIND_NOLISTEN"), primary.subList(0, 4));
        assertEquals(List.of("AUTH_CHALLENGE", "AUTH_RESPONSE", "Receive"), callback);
    }

    @Test
    void aWrongSecretFailsTheConnect() {
        RequestFailedException e = assertThrows(RequestFailedException.class,
                () -> module = OpenAir.connect(options("not-the-secret-0123").build()));
        assertTrue(e.getMessage().contains("AUTH_FAILED"), e.getMessage());
        assertTrue(fake.history.stream().noneMatch(r -> r.message().type().startsWith("BIND")));
    }

    @Test
    void aServerWithoutAuthNeverSeesBind() {
        fake.advertised = Set.of("noreply");
        assertThrows(ApiMisuseException.class,
                () -> module = OpenAir.connect(options(SECRET).build()));
        assertTrue(fake.history.stream().noneMatch(r -> r.message().type().startsWith("BIND")
                || r.message().type().startsWith("AUTH")));
    }

    @Test
    void withoutASecretNothingChanges() throws Exception {
        module = OpenAir.connect(options(null).build());
        assertTrue(fake.history.stream().noneMatch(r -> r.message().type().startsWith("AUTH")));
        Message sent = module.post("WB1", "Test.Plain", "x");
        assertEquals("Test.Plain", sent.type());
    }

    /** A PKCS12 key store with a self-signed key for 127.0.0.1, made by the JDK's keytool. */
    static KeyStore selfSigned(Path dir) throws Exception {
        Path file = dir.resolve("server.p12");
        Process p = new ProcessBuilder("keytool", "-genkeypair", "-keystore", file.toString(),
                "-storetype", "PKCS12", "-storepass", "changeit", "-keypass", "changeit",
                "-alias", "server", "-keyalg", "RSA", "-keysize", "2048", "-dname",
                "CN=127.0.0.1", "-ext", "san=ip:127.0.0.1", "-validity", "1")
                .redirectErrorStream(true).start();
        String out = new String(p.getInputStream().readAllBytes(), StandardCharsets.UTF_8);
        assertEquals(0, p.waitFor(), out);
        KeyStore store = KeyStore.getInstance("PKCS12");
        try (InputStream in = Files.newInputStream(file)) {
            store.load(in, "changeit".toCharArray());
        }
        return store;
    }

    @Test
    void tlsWithTheServersCertificate(@TempDir Path dir) throws Exception {
        KeyStore store = selfSigned(dir);
        KeyManagerFactory kmf =
                KeyManagerFactory.getInstance(KeyManagerFactory.getDefaultAlgorithm());
        kmf.init(store, "changeit".toCharArray());
        TrustManagerFactory tmf =
                TrustManagerFactory.getInstance(TrustManagerFactory.getDefaultAlgorithm());
        tmf.init(store);
        SSLContext serverTls = SSLContext.getInstance("TLS");
        serverTls.init(kmf.getKeyManagers(), null, null);
        SSLContext clientTls = SSLContext.getInstance("TLS");
        clientTls.init(null, tmf.getTrustManagers(), null);
        fake.close();
        fake = secure(new FakeServer(serverTls.getServerSocketFactory()
                .createServerSocket(0, 50, InetAddress.getLoopbackAddress())));
        module = OpenAir.connect(options(SECRET).sslSocketFactory(clientTls.getSocketFactory())
                .build());
        assertEquals("Test.Tls", module.post("WB1", "Test.Tls", "over TLS").type());
        assertTrue(fake.history.stream().anyMatch(r -> r.tag() == Frame.Tag.RECEIVE));
        module.close();
        module = null;
        SSLContext untrusting = SSLContext.getInstance("TLS");
        untrusting.init(null, null, null); // the JDK's CAs: the self-signed key is not one
        assertThrows(ConnectionClosedException.class, () -> module = OpenAir.connect(
                options(SECRET).sslSocketFactory(untrusting.getSocketFactory()).build()));
    }
}
