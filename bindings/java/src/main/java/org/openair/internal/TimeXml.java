package org.openair.internal;

import java.math.BigDecimal;
import java.math.MathContext;
import java.math.RoundingMode;
import java.util.Map;
import java.util.regex.Pattern;
import org.openair.AirTime;
import org.openair.ApiMisuseException;
import org.openair.RemoteProtocolException;
import org.w3c.dom.Document;
import org.w3c.dom.Element;

/**
 * Times and decimals in XML (spec section 4, 3.2): reading {@code sec}/{@code msec}/{@code usec}
 * leniently (OA-TIME-1, OA-TIME-6), writing them canonically, and the shortest decimal form of
 * {@code priority} and {@code timetolive}.
 *
 * <p>Threading: stateless; thread-safe.
 */
public final class TimeXml {
    private static final Pattern INT = Pattern.compile("[+-]?[0-9]+");
    private static final Pattern UINT = Pattern.compile("\\+?[0-9]+");

    private TimeXml() {}

    /**
     * Read a time element (OA-TIME-1): {@code sec}, {@code msec} (or {@code ms}), {@code usec}.
     *
     * @param el the element
     * @return the time
     * @throws RemoteProtocolException MESSAGE_INVALID for a bad value (OA-TIME-6)
     */
    public static AirTime timeFromElement(Element el) {
        return timeFromAttributes(Codec.attributes(el), el.getTagName());
    }

    static AirTime timeFromAttributes(Map<String, String> attrs, String where) {
        String secText = attrs.get("sec");
        if (secText == null) {
            throw Codec.invalid("<" + where + "> has no sec attribute");
        }
        String s = Dom.strip(secText);
        if (!INT.matcher(s).matches()) { // OA-TIME-6
            throw Codec.invalid("sec of <" + where + "> is not a decimal integer: '" + Codec.clip(s) + "'");
        }
        long sec;
        try {
            sec = Long.parseLong(s); // OA-TIME-1: signed 64-bit
        } catch (NumberFormatException e) {
            throw Codec.invalid("sec of <" + where + "> is outside the 64-bit range: '" + Codec.clip(s) + "'");
        }
        String msecText = attrs.containsKey("msec") ? attrs.get("msec") : attrs.get("ms");
        int msec = msecText == null ? 0 : below1000(msecText, "msec of <" + where + ">");
        String usecText = attrs.get("usec"); // OA-TIME-5
        Integer usec = usecText == null ? null : below1000(usecText, "usec of <" + where + ">");
        return new AirTime(sec, msec, usec);
    }

    private static int below1000(String text, String what) {
        String s = Dom.strip(text);
        if (!UINT.matcher(s).matches()) { // OA-TIME-6
            throw Codec.invalid(what + " is not a non-negative integer: '" + Codec.clip(s) + "'");
        }
        String digits = s.startsWith("+") ? s.substring(1) : s;
        digits = digits.replaceFirst("^0+(?=.)", "");
        if (digits.length() > 3 || Integer.parseInt(digits) > 999) {
            throw Codec.invalid(what + " must be 0-999, got '" + Codec.clip(text) + "'");
        }
        return Integer.parseInt(digits);
    }

    /**
     * Write a time as {@code <name sec msec/>}, plus {@code usec} when present (OA-TIME-5).
     *
     * @param name the element name
     * @param t the time
     * @param doc the owner document
     * @return the element
     */
    public static Element timeElement(String name, AirTime t, Document doc) {
        Element el = doc.createElement(name);
        SafeXml.setAttr(el, "sec", Long.toString(t.sec()));
        SafeXml.setAttr(el, "msec", Integer.toString(t.msec()));
        if (t.usec() != null) {
            SafeXml.setAttr(el, "usec", Integer.toString(t.usec()));
        }
        return el;
    }

    /**
     * Write a decimal as the shortest digits that read back as {@code value}, never with an
     * exponent and always with a fraction: {@code 2.0}, {@code 0.5}, {@code 6.999}.
     *
     * @param value the number
     * @param what its name, for the error
     * @return the text
     */
    public static String formatDecimal(double value, String what) {
        if (!Double.isFinite(value)) {
            throw new ApiMisuseException(what + " must be a finite number, got " + value);
        }
        double v = value + 0.0;
        BigDecimal exact = new BigDecimal(v);
        BigDecimal shortest = exact;
        for (int digits = 1; digits <= 17; digits++) {
            BigDecimal candidate =
                    exact.round(new MathContext(digits, RoundingMode.HALF_EVEN));
            if (candidate.doubleValue() == v) {
                shortest = candidate;
                break;
            }
        }
        String text = shortest.stripTrailingZeros().toPlainString();
        return text.contains(".") ? text : text + ".0";
    }
}
