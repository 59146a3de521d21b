package org.openair.internal;

import java.io.IOException;
import java.io.InputStream;
import java.io.OutputStream;
import java.net.Socket;
import java.net.SocketTimeoutException;
import java.nio.charset.StandardCharsets;
import java.security.GeneralSecurityException;
import java.time.Duration;
import java.util.HexFormat;
import java.util.List;
import javax.crypto.Mac;
import javax.crypto.spec.SecretKeySpec;
import javax.net.ssl.SSLParameters;
import javax.net.ssl.SSLSocket;
import javax.net.ssl.SSLSocketFactory;
import org.openair.ApiMisuseException;
import org.openair.Capabilities;
import org.openair.ConnectionClosedException;
import org.openair.Message;
import org.openair.Options;
import org.openair.RequestFailedException;
import org.openair.RequestTimeoutException;

/**
 * Secure mode on the client side (spec 14.3, extension {@code auth}): TLS connections through the
 * options' {@link SSLSocketFactory} (OA-AUTH-10), and the proof of the module's name with
 * AUTH_CHALLENGE and AUTH_RESPONSE before anything acts for it (OA-AUTH-3, OA-AUTH-6).
 */
final class Auth {
    private static final String LABEL = "OpenAIR-auth/1";
    private static final String CNS = "CNS";

    private Auth() {}

    /**
     * Compute the proof of {@code name} for {@code nonce}: lowercase hex
     * HMAC-SHA256(secret, "OpenAIR-auth/1" LF nonce LF name) (OA-AUTH-3).
     *
     * @param secret the module's secret
     * @param nonce the server's nonce (hex)
     * @param name the module's name
     * @return the proof
     */
    static String proof(String secret, String nonce, String name) {
        try {
            Mac mac = Mac.getInstance("HmacSHA256");
            mac.init(new SecretKeySpec(secret.getBytes(StandardCharsets.UTF_8), "HmacSHA256"));
            byte[] data = (LABEL + "\n" + nonce + "\n" + name).getBytes(StandardCharsets.UTF_8);
            return HexFormat.of().formatHex(mac.doFinal(data));
        } catch (GeneralSecurityException e) {
            throw new IllegalStateException("HmacSHA256 is not available", e); // every JDK has it
        }
    }

    /**
     * Open a connection to the server: TLS when the options have a socket factory (the host
     * name is verified against the certificate), plain TCP otherwise.
     */
    static Socket connect(Options o, String host, int port) {
        Socket plain = Link.connect(host, port, o.connectTimeout());
        SSLSocketFactory tls = o.sslSocketFactory();
        if (tls == null) {
            return plain;
        }
        try {
            SSLSocket s = (SSLSocket) tls.createSocket(plain, host, port, true);
            SSLParameters p = s.getSSLParameters();
            p.setEndpointIdentificationAlgorithm("HTTPS"); // OA-AUTH-10: verify the server
            s.setSSLParameters(p);
            s.setSoTimeout((int) Math.min(Integer.MAX_VALUE, o.connectTimeout().toMillis()));
            s.startHandshake();
            s.setSoTimeout(0);
            return s;
        } catch (IOException e) {
            Link.closeQuietly(plain);
            throw new ConnectionClosedException("TLS with " + host + ":" + port + " failed: "
                    + e.getMessage());
        }
    }

    /** Refuse a server that does not advertise {@code auth} when a secret is set (OA-AUTH-12). */
    static void checkSecure(Options o, Capabilities caps) {
        if (o.secret() != null && (caps == null || !caps.extensions().contains("auth"))) {
            throw new ApiMisuseException("a secret is set but the server does not run in secure"
                    + " mode (no auth extension, OA-AUTH-12)");
        }
    }

    /** Prove the module's name on a requester link, if the options have a secret. */
    static void prove(Options o, Link l) {
        if (o.secret() == null) {
            return; // legacy mode: nothing changes on the wire
        }
        Message[] nonce = l.request(challenge(o), o.requestTimeout());
        Message[] reply = l.request(response(o, nonce), o.requestTimeout());
        accepted(reply);
    }

    /**
     * Prove the module's name on a fresh socket before its Receive frame (OA-AUTH-6), with a
     * throwaway requester session; does nothing without a secret.
     */
    static void prove(Options o, Socket socket, Session session) {
        if (o.secret() == null) {
            return;
        }
        try {
            socket.setSoTimeout((int) Math.min(Integer.MAX_VALUE, o.requestTimeout().toMillis()));
            Message[] nonce = exchange(socket, session, challenge(o));
            accepted(exchange(socket, session, response(o, nonce)));
            socket.setSoTimeout(0);
        } catch (SocketTimeoutException e) {
            Link.closeQuietly(socket);
            throw new RequestTimeoutException("no reply while proving the name");
        } catch (IOException e) {
            Link.closeQuietly(socket);
            throw new ConnectionClosedException("connection lost while proving: " + e.getMessage());
        } catch (RuntimeException e) {
            Link.closeQuietly(socket);
            throw e;
        }
    }

    private static Message challenge(Options o) {
        return Message.builder("AUTH_CHALLENGE").sender(o.name()).to(CNS).build();
    }

    private static Message response(Options o, Message[] nonce) {
        if (!nonce[1].type().equals("AUTH_NONCE")) {
            throw new RequestFailedException(nonce[0], nonce[1]);
        }
        String proof = proof(o.secret().value(), Dom.strip(nonce[1].content()), o.name());
        return Message.builder("AUTH_RESPONSE").sender(o.name()).to(CNS).content(proof).build();
    }

    private static void accepted(Message[] reply) {
        if (!reply[1].type().equals("AUTH_ACCEPT")) {
            throw new RequestFailedException(reply[0], reply[1]); // AUTH_FAILED: detail
        }
    }

    /** Send one request on a raw socket and read until its reply. */
    private static Message[] exchange(Socket socket, Session session, Message request)
            throws IOException {
        OutputStream out = socket.getOutputStream();
        out.write(session.sendRequest(request));
        out.flush();
        Message sent = session.lastSent();
        InputStream in = socket.getInputStream();
        byte[] buffer = new byte[8192];
        while (true) {
            int n = in.read(buffer);
            List<Session.Event> events =
                    n < 0 ? session.receiveEof() : session.receive(buffer, 0, n);
            for (Session.Event e : events) {
                if (e instanceof Session.Reply r) {
                    return new Message[] {sent, r.message()};
                }
            }
            if (n < 0) {
                throw new ConnectionClosedException("the server closed while proving the name");
            }
        }
    }
}
