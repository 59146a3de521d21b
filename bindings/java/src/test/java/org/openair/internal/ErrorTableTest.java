package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertInstanceOf;
import static org.junit.jupiter.api.Assertions.assertNotNull;

import java.nio.file.Files;
import java.nio.file.Path;
import java.util.List;
import java.util.Locale;
import org.junit.jupiter.api.Test;
import org.openair.ApiMisuseException;
import org.openair.ConnectionClosedException;
import org.openair.ErrorCode;
import org.openair.LocalProtocolException;
import org.openair.OpenAirException;
import org.openair.PeerException;
import org.openair.RemoteProtocolException;
import org.openair.RequestTimeoutException;
import org.w3c.dom.Element;

/** The generated ErrorCode agrees with spec/errors.xml, and exceptions follow the blame. */
class ErrorTableTest {
    @Test
    void everyRowOfTheTableIsAnErrorCode() throws Exception {
        Path table = Vectors.root().resolve("..").resolve("errors.xml").normalize();
        Element root = SafeXml.parse(Files.readAllBytes(table), 1 << 20, 8);
        List<Element> rows = Dom.children(root);
        assertEquals(rows.size(), ErrorCode.values().length);
        for (Element row : rows) {
            ErrorCode code = ErrorCode.byName(row.getAttribute("name"));
            assertNotNull(code, row.getAttribute("name"));
            assertEquals(Integer.parseInt(row.getAttribute("code")), code.code());
            assertEquals(row.getAttribute("blame").toUpperCase(Locale.ROOT), code.blame().name());
            assertEquals("yes".equals(row.getAttribute("closes")), code.closes());
        }
    }

    @Test
    void exceptionsFollowTheBlame() {
        for (ErrorCode code : ErrorCode.values()) {
            OpenAirException e = OpenAirException.of(code, "d");
            assertEquals(code, e.code());
            assertEquals(code.name() + ": d", e.wireText()); // OA-ERR-2
            switch (code.blame()) {
                case REMOTE -> assertInstanceOf(RemoteProtocolException.class, e);
                case PEER -> assertInstanceOf(PeerException.class, e);
                case LOCAL -> assertInstanceOf(LocalProtocolException.class, e);
                default -> throw new AssertionError(code);
            }
        }
        assertInstanceOf(RequestTimeoutException.class,
                OpenAirException.of(ErrorCode.REQUEST_TIMEOUT, ""));
        assertInstanceOf(ConnectionClosedException.class,
                OpenAirException.of(ErrorCode.CONNECTION_CLOSED, ""));
        assertInstanceOf(ApiMisuseException.class, OpenAirException.of(ErrorCode.API_MISUSE, ""));
        assertEquals("API_MISUSE", new ApiMisuseException("").wireText());
    }
}
