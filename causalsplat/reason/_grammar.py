"""Phrase tables of the offline parser: relation cues, modifiers, triggers.

Cues are regular expressions over the space-joined tokens of :mod:`causalsplat.reason._text`
(so ``"to the left of"`` matches the tokens ``to the left of``); the longest cue starting
at a token wins. The vocabulary covers the templates of Sr3D and the common phrasings of
Nr3D and ScanRefer.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from queries import Metric, Op

#: Words for rooms, never an anchor object of their own.
ROOMS = frozenset({"room", "bedroom", "bathroom", "kitchen", "office", "hallway", "hall",
                   "lobby", "classroom", "restroom", "lounge", "studio", "apartment",
                   "closet"})  # fmt: skip
#: Rooms that, right before a noun, say where the thing is rather than what kind of thing
#: it is: "the bathroom door" is the door by the bathroom. Not "office" (an office chair is
#: a kind of chair, wherever it stands) nor "closet" (a thing of its own).
ROOM_MODIFIERS = frozenset({"bedroom", "bathroom", "kitchen", "restroom"})
#: Relation kinds a cue can name. Stored relations keep their RelationType value;
#: ``closest`` / ``farthest`` / ``between`` / ``with`` are handled by the planner.
_SIDE = r"(?:(?:to|on|at|towards?) )?(?:the )?(?:(?:far|very) )?"
#: A superlative side before a partitive "of": "the furthest right of the four bottles" is
#: the rightmost of them, not something right of them.
_MOST_SIDE = r"(?:the |one )?(?:furthest|farthest|most) (?:to the )?"
#: A small count of things ("the two chairs", "the 3 of them").
_COUNT = r"(?:two|three|four|five|six|both|\d+)"
#: "the left (hand one) of the two chairs": one of a counted group, not something left of it.
_OF_COUNT = r"(?: hand)?(?: one)? of(?= (?:the |these |those )?" + _COUNT + " )"
#: Words for the room as a whole ("in the middle of the room", "in the corner of the office").
_ROOM = r"(?:room|space|area)"
#: "... with two": how many of a kind a side of the room or a wall has.
_HAVING = (
    r"(?:with|that has|which has|having|where there are|that have) (?:the )?"
    r"(?:two|three|four|five|six|[2-9])"
)
#: What of the room's depth a place names ("the back side", "the front part").
_DEPTH_PART = r"(?: (?:side|end|part|half|section|area|row))?"


def _depth(word: str) -> str:
    """A place in the room's depth ("at the back", "in the front left of the room", "on
    the back right"); "on the back" alone is a part of a thing ("holes on the back")."""
    at = r"(?:in|at|to|towards?) the (?:very |far )?" + word + r"(?: (?:left|right))?"
    on = r"on the (?:very |far )?" + word + r"(?: (?:left|right)| (?=side|end|part))"
    end = _DEPTH_PART + r"(?: of (?:the|this) " + _ROOM + r"|(?! of\b))"
    return rf"(?:{at}|{on}){end}|on the (?:very |far )?{word}{_DEPTH_PART} of (?:the|this) {_ROOM}"


CUE_PATTERNS: tuple[tuple[str, str], ...] = (
    ("left_of", r"(?!the left" + _OF_COUNT + ")" + _SIDE + r"left(?: hand)?(?: side)? of"),
    ("right_of", r"(?!the right" + _OF_COUNT + ")" + _SIDE + r"right(?: hand)?(?: side)? of"),
    ("side_left", r"(?:on|to|at|in|towards?) the (?:far |very )?left(?: hand)?(?: side)?|"
                  + _MOST_SIDE + "left(?= (?:one |ones )?of )|the left" + _OF_COUNT),
    ("side_right", r"(?:on|to|at|in|towards?) the (?:far |very )?right(?: hand)?(?: side)?|"
                   + _MOST_SIDE + "right(?= (?:one |ones )?of )|the right" + _OF_COUNT),
    ("side_middle", r"(?:in|at) the (?:very )?(?:middle|center|centre)"
                    r"(?: of (?:the|a|this) (?:group|row|line|set|cluster|bunch|series|others|"
                    r"rest)(?: of)?| of the(?= " + _COUNT + " ))?"),
    ("place_centre", r"(?:(?:in|at|near|towards?|by) )?the (?:very |exact )?"
                     r"(?:middle|center|centre) of (?:the|this) " + _ROOM),
    ("place_corner", r"(?:in|at|on|into|near|towards?|by) (?:the|a) (?:(?:far|back|front|"
                     r"(?:north|south)?(?:east|west)|north|south|northern|southern|eastern|"
                     r"western) )?(?:(?:left|right) (?:hand )?)?corner"
                     r"(?: of (?:the|this) " + _ROOM + r"|(?! of))"),
    # "at the back of the room", "in the front left", "at the far end of the room": how
    # far ahead of the observer, not behind or in front of a thing ("at the back of the
    # desk" has "of" and a thing after it)
    ("depth_back", _depth(r"(?:back|rear)") + r"|(?:in|at|on|to|towards?) the (?:far|other|"
                   r"opposite) end of (?:the|this) " + _ROOM),
    ("depth_front", _depth("front") + r"|(?:in|at|on|to|towards?) the near end of (?:the|this) "
                    + _ROOM),
    # "on the side with two trash cans", "on the wall with 3 pictures": of the room's two
    # sides, the one where that many of them stand together (the count ends the cue)
    ("side_with", r"(?:(?:on|at|in|along|by|against) )?the (?:side|end|half|part|area|"
                  r"section|wall)(?: of (?:the|this) " + _ROOM + r")? " + _HAVING),
    ("place_alone", r"(?:all )?(?:by (?:it|them)sel(?:f|ves)|on (?:its|their) own|alone|"
                    r"isolated|lone|solitary|apart from the others)"),
    # "at the end of the table", "at the head of the table" (not "the end of the room")
    ("end_of", r"(?:(?:at|on|by|near|to|towards?) )?(?:the|one|either|each) "
               r"(?:(?:very|far|other|opposite|short|narrow|front|back|near|left|right) )?"
               r"(?:end|head)(?: side)? of(?= (?:the|a|this) (?!" + _ROOM + r"\b))"),
    ("corner_of", r"(?:(?:at|on|in|into|by|near|to|towards?) )?(?:the|a|one) "
                  r"(?:(?:near|far|front|back|left|right|[a-z]+ (?:left|right)) )?"
                  r"corner of(?= (?:the|a|this) (?!" + _ROOM + r"\b))"),
    ("in_front_of", r"(?:(?:directly|right|just) )?in front of|(?:on|at|in) the front of"),
    ("behind", r"(?:(?:directly|right|just) )?behind|in back of|"
               r"(?:on|at|to) the back(?: side)? of"),
    ("between", r"(?:(?:directly|right|just) )?(?:in )?between|"
                r"in the (?:middle|center|centre) of"),
    ("farthest", r"(?:the )?(?:(?:farthest|furthest|farther|further|far)(?: away)?|away) from|"
                 r"(?:the )?(?:farthest|furthest)(?= (?!left |right |to )(?:\S+ ){1,3}from )"),
    ("closest", r"(?:the )?(?:closest|nearest|closer|nearer)(?: to)?|"
                # "closes to the sink": a common slip for "closest to"
                r"closes to|"
                # "with its back to the wall", "has its back to the kitchen": turned away
                # from it, and by it
                r"(?:with |has |have )?(?:its|their) backs? (?:turned |facing )?(?:to|towards?)|"
                # "it is facing a stool", "the one that faces the table": turned to it,
                # read as the closest to it (the observer facing a thing is a viewpoint)
                r"(?<!you are )(?<!you're )(?<!youre )(?<!you )(?<!i am )(?<!we are )"
                r"(?:facing|faces)(?: towards?)?(?= (?:the|a|an|some|two|three) )|"
                # "on the same wall as the sink", "same side as where the dresser is":
                # beside it along the room's side, read as the closest to it
                r"(?:(?:on|at|along|against|by|in) )?(?:the )?same "
                r"(?:side|wall|end|corner|part|half)(?: of (?:the|this) " + _ROOM + r")? as"
                r"(?: (?:where|what))?"),
    # "the door to the bathroom", "the one that opens into the kitchen": by that room
    ("closest", r"(?:(?:leads?|leading|opens?|opening|open|goes|going) )?(?:in)?to the"
                r"(?= (?:" + "|".join(sorted(ROOM_MODIFIERS)) + r")\b)"),
    ("opposite", r"(?:(?:directly|right|just|diagonally) )?"
                 r"(?:across from|opposite(?: to| from| of)?)|"
                 # "on the other side of the table" (not "... of the room": a place)
                 r"(?:on|at|to) the (?:other|opposite) side of(?= (?:the|a|an|this) (?!"
                 + _ROOM + r"\b))"),
    # "on the long side of the table", "at the side of the desk": beside it, not on it;
    # the far / near side of it is behind / in front of it as the observer sees it (not
    # "... of the room": a place)
    ("near", r"(?:on|at|by|along|to) (?:the|one|either|each) (?:(?!(?:left|right|other|"
             r"opposite|far|near|back|front)\b)[a-z]+ )?side of(?= (?:the|a|an|this) (?!"
             + _ROOM + r"\b))"),
    ("behind", r"(?:on|at|to) the far(?:ther|thest)? side of(?= (?:the|a|an|this) (?!"
               + _ROOM + r"\b))"),
    ("in_front_of", r"(?:on|at) the near(?:er|est)? side of(?= (?:the|a|an|this) (?!"
                    + _ROOM + r"\b))"),
    ("near", r"(?:(?:right|directly|just|located|placed|sitting|standing) )?"
             r"(?:near(?: to)?|next to|beside|besides|by(?! (?:it|them)sel)|adjacent to|"
             r"alongside|close to|"
             r"nearby|against|at)"),
    ("supported_by", r"(?:(?:lying|laying|sitting|resting|placed|standing|stacked|set|sits|"
                     r"rests|lies|stands|kept|put|located) )?"
                     r"(?:on (?:the )?top of|on top|atop|on|onto|upon)|supported by"),
    ("supports", r"supporting|supports|holding|holds"),
    ("above", r"(?:(?:directly|right|just|hanging|hung|mounted|located) )?"
              r"(?:above|over|higher than)"),
    ("below", r"(?:(?:directly|right|just|tucked|pushed|located) )?"
              r"(?:below|under|underneath|beneath|lower than)"),
    ("contains", r"containing|contains"),
    ("inside", r"inside of|inside|within|into|in"),
    ("with", r"with|that has|which has|that have|which have|has|have"),
)  # fmt: skip
CUES: tuple[tuple[str, re.Pattern[str]], ...] = tuple(
    (kind, re.compile(rf"(?:{pattern})(?= |$)")) for kind, pattern in CUE_PATTERNS
)

#: Relation kinds that read "the anchor is <kind> the target" after "with NP ...":
#: "the table with a lamp on it" -> lamp supported_by table -> table supports lamp.
WITH_TAIL: dict[str, str] = {
    "supported_by": "supports",
    "inside": "contains",
    "below": "above",
    "above": "below",
    "near": "near",
    "left_of": "right_of",
    "right_of": "left_of",
    "in_front_of": "behind",
    "behind": "in_front_of",
}
#: Words after a "with NP" tail cue that point back at the target ("on it", "on top").
BACK_REFERENCES = frozenset({"it", "its", "them", "their", "top", "itself", "this", "that"})

NEGATIONS = frozenset({"not", "no", "never", "except", "without", "neither", "nor"})
PRONOUNS = frozenset({"it", "them", "this", "that", "these", "those", "its", "itself", "they"})
#: Possessive determiners ("my hands", "their cups").
POSSESSIVES = frozenset({"my", "your", "our", "his", "her", "their", "its"})
#: Determiners of a definite noun phrase: one the speaker takes to be known ("the cup",
#: "my phone").
DEFINITE = POSSESSIVES | {"the", "this", "that", "these", "those"}
DETERMINERS = DEFINITE | {"a", "an", "some", "any", "another", "other", "each", "every"}
#: Nouns for one level of a piece of furniture ("the top shelf of the bookcase").
LEVELS = frozenset({"shelf", "shelves", "level", "levels", "tier", "tiers", "row", "rows",
                    "layer", "layers", "rack"})  # fmt: skip
#: Nouns that name places or parts, never a target or anchor of their own.
SPATIAL_NOUNS = frozenset({
    "top", "bottom", "side", "left", "right", "front", "back", "middle", "center", "centre",
    "corner", "end", "edge", "part", "area", "room", "way", "spot", "place", "space", "group",
    "row", "set", "lot", "one", "ones", "thing", "things", "object", "objects", "item", "items",
    "something", "anything", "stuff", "somewhere", "direction", "view", "position", "line",
    "pair", "couple", "rest", "kind", "type", "piece", "bit", "half", "number", "foot", "head",
    "entrance", "hand", "hands", "time", "person", "people", "you", "i", "me", "question",
})  # fmt: skip
#: Function words that are never read as nouns ("can", "down" are nouns in WordNet too).
FUNCTION_WORDS = frozenset({
    "can", "could", "will", "would", "may", "might", "must", "shall", "should", "do", "does",
    "did", "is", "are", "was", "were", "be", "been", "being", "am", "have", "has", "had", "i",
    "you", "he", "she", "we", "they", "me", "down", "up", "out", "off", "there", "here",
    "how", "when", "why", "yes", "all", "some", "any", "also", "just", "very", "really",
    "please", "to", "as", "than", "then", "so", "if", "but", "find", "choose", "select",
    "pick", "get", "go", "look", "see", "want", "need", "like", "located", "placed", "near",
    "next", "far", "close", "left", "right", "front", "back", "behind", "below", "above",
    "under", "between", "middle", "center", "centre", "side", "top", "bottom", "set", "put",
})  # fmt: skip
#: English function words (pronouns, determiners, prepositions, conjunctions, auxiliaries)
#: that WordNet does not list: words, never misspellings (:mod:`~causalsplat.reason._spelling`).
CLOSED_CLASS = (
    FUNCTION_WORDS | DETERMINERS | PRONOUNS | POSSESSIVES | NEGATIONS | frozenset({
        "what", "which", "where", "whose", "whom", "while", "whilst", "with", "within",
        "from", "into", "onto", "upon", "over", "across", "along", "alongside", "around",
        "about", "against", "among", "amongst", "atop", "before", "beneath", "beside",
        "besides", "beyond", "during", "inside", "outside", "through", "throughout", "toward",
        "towards", "underneath", "unto", "until", "unless", "though", "although", "because",
        "whether", "either", "neither", "nor", "theirs", "yours", "ours", "mine", "hers",
        "himself", "herself", "myself", "yourself", "themselves", "ourselves", "both",
        "others", "such", "much", "many", "more", "most", "less", "least", "few", "fewer",
        "only", "thats", "whats", "theres", "cannot", "ought", "once", "twice", "again",
        "ever", "none",
    })
)  # fmt: skip
#: What makes a request about an action or a need ("where can I ...", "something to ...").
#: "to" as the mark of an infinitive ("something to sit on"), not the preposition of a
#: place ("the thing to the left of the fridge").
_INFINITIVE_TO = r"to\b(?! (?:the|a|an|this|that|these|those|its|his|her|their|our|your|my)\b)"
ACTION_TRIGGERS = re.compile(
    r"\b(?:can|could|may|should|might) (?:i|we|you|one|someone)\b|"
    r"\b(?:something|somewhere|anything|anywhere|someplace|place|thing|things|stuff|"
    rf"objects?|items?)(?: [a-z]+)? (?:{_INFINITIVE_TO}|for\b)|"
    r"\b(?:something|somewhere|anything|anywhere|someplace|place|thing|things|stuff|"
    rf"objects?|items?|what|where) (?:{_INFINITIVE_TO}|(?:for|i|you)\b)|"
    # "something that ...", but not "the thing that is left of the fridge"
    r"(?<!the )\b(?:something|somewhere|anything|anywhere|someplace|place|thing|things|"
    r"stuff|objects?|items?|what|where) (?:that|which)\b|"
    r"\b(?:i|we) (?:want|need|would like|wanna|have|am going) to\b|"
    r"\b(?:used|good|useful) (?:to|for)\b|"
    # where a thing belongs: "where do dirty clothes go?", "where does this box belong?"
    r"\bwhere (?:do|does|should|would|could|can|might|will) (?:[a-z]+ ){1,4}"
    r"(?:go|belong|live)\b|"
    # what the speaker has calls for something: "I have a runny nose", "I've got dirty dishes"
    r"^(?:i|we) (?:have|got|have got)\b(?! to\b)|"
    r"\b(?:i|we)(?: really| just| also| still| now| badly)? (?:need|want|require|desire|"
    r"wish|hope|must|should|would like|like|am seeking|am looking for|am searching for|"
    r"am after|have to|got to|gotta)\b"
)
#: Where the purpose clause of a need begins: right after one of these ("where can I |heat
#: up soup", "I need a place to |keep my food cold", "something for |cleaning").
PURPOSE_FRAMES = re.compile(
    r"\b(?:can|could|may|should|might|would|do) (?:i|we|you|one|someone)\b|"
    r"\b(?:want|wants|need|needs|like|wanna|going|have|has|trying|try|hoping|hope|wish|"
    r"plan|planning) to\b|"
    r"\b(?:something|somewhere|anything|anywhere|someplace|place|spot|thing|things|stuff|"
    r"way|item|items|object|objects)(?: [a-z]+)? "
    rf"(?:{_INFINITIVE_TO}|(?:for|that i can|i can|we can)\b)|"
    r"\b(?:need|needs|want|wants|use) (?:it|them|one) (?:to|for)\b|\bwhere to\b|"
    r"\b(?:used|good|useful|meant|made) (?:to|for)\b|\bin order to\b|\bso (?:that )?i can\b"
)
#: Verbs of getting or finding: their object is the thing wanted itself ("where can I
#: find a mug"), not a word of the purpose.
FETCH_VERBS = frozenset({
    "find", "get", "grab", "fetch", "bring", "take", "pick", "see", "locate", "reach", "use",
    "show", "give", "hand", "buy", "borrow", "look", "point", "choose", "select", "identify",
    "spot", "have",
})  # fmt: skip
#: Words that stand for "any entity" as a target.
GENERIC_TARGETS = frozenset({"one", "ones", "thing", "things", "object", "objects", "item",
                             "items", "something", "anything", "stuff", "everything",
                             "what", "which", "where"})  # fmt: skip
WH_WORDS = frozenset({"what", "which", "where", "who", "whatever"})
VIEW_TRIGGERS = frozenset({"facing", "face", "looking", "look", "standing", "stand", "stood",
                           "sitting", "sat",
                           "viewing", "view", "seen", "entering", "enter", "walking",
                           *(_ENTERING := frozenset({"enters", "entered", "walk", "walks",
                                                     "walked", "come", "comes", "coming",
                                                     "came"})),
                           "back"})  # fmt: skip
#: Whose back a viewpoint's "back" must be ("with your back to the window"; never "the
#: chair with its back to the wall", which says which way the chair faces).
OBSERVER_POSSESSIVES = frozenset({"your", "my", "our", "one", "ones"})
#: Words that open a viewpoint clause inside a sentence ("the chair on the left *when*
#: facing the bed") and words for the observer that may stand before its trigger.
VIEW_SUBORDINATORS = frozenset({"when", "if", "while", "as", "whilst", "once", "after"})
VIEW_OBSERVER = frozenset({"when", "if", "while", "as", "whilst", "once", "after", "you",
                           "are", "your", "youre", "i", "am", "we", "one", "is", "imagine",
                           "just", "now", "and", "so", "currently", "re", "were",
                           "be"})  # fmt: skip
#: Words that start the main clause after a viewpoint clause that has no comma.
VIEW_CLAUSE_OPENERS = frozenset({"this", "these", "those", "they", "choose",
                                 "chose", "select", "pick", "click", "find", "there", "then",
                                 "target", "correct"})  # fmt: skip
#: Where someone stands who faces the entity: "at the foot of the bed", "in front of it".
FACING_PLACES = frozenset({"foot", "front"})
#: Viewpoint triggers that say where the observer looks.
LOOKING = frozenset({"facing", "face", "looking", "look", "viewing", "view", "seen", "toward",
                     "towards"})  # fmt: skip
#: Viewpoint triggers after which the observer stands *at* the anchor (not looking at it).
STANDING_AT = frozenset({"standing", "stand", "stood", "sitting", "sit", "sat", "entering",
                         "enter", "walking", "back",
                         *_ENTERING})  # fmt: skip
REMOVAL_TRIGGERS = re.compile(
    r"\b(?:remov\w*|take[ns]? away|took away|taking away|pull(?:ed|s)? (?:out|away)|"
    r"gone|disappear\w*|was not there|were not there|is not there|are not there|"
    r"(?:got|get|gets|is|are|were|was) moved|delet\w*|knocked over)\b"
)
FALL_TRIGGERS = re.compile(
    r"\b(?:fall\w*|fell|drop\w*|collapse\w*|tumble\w*|topple\w*)\b|"
    # a question of what reaches the floor: "what hits the floor?", "which things end up on
    # the ground?", "what comes crashing down to the floor?"
    r"\b(?:what|which)\b.*\b(?:hit\w*|land\w*|end\w* up|crash\w*|(?:come|comes|came|go|goes|"
    r"went) down)(?: on| onto| to| into| down to| on to)? (?:the )?(?:floor|ground)\b"
)
CLOSURE_TRIGGERS = re.compile(r"\b(?:stacked|everything|all (?:the )?things|piled)\b")

#: Superlatives and size adjectives: word -> (metric, argmax or argmin). Long, wide and
#: narrow rank by the longer side of the footprint (a table's length, a window's width);
#: thin, skinny and slender say what shape a thing has, not which is longer, and are not
#: among them.
_BIG, _SMALL = (Metric.VOLUME, Op.ARGMAX), (Metric.VOLUME, Op.ARGMIN)
_TALL, _SHORT = (Metric.HEIGHT, Op.ARGMAX), (Metric.HEIGHT, Op.ARGMIN)
_HIGH, _LOW = (Metric.Z, Op.ARGMAX), (Metric.Z, Op.ARGMIN)
_LONG, _NARROW = (Metric.LENGTH, Op.ARGMAX), (Metric.LENGTH, Op.ARGMIN)
EXTREMES: dict[str, tuple[Metric, Op]] = {
    "largest": _BIG, "biggest": _BIG, "larger": _BIG, "bigger": _BIG, "large": _BIG,
    "big": _BIG, "huge": _BIG,
    "smallest": _SMALL, "smaller": _SMALL, "small": _SMALL, "little": _SMALL, "tiny": _SMALL,
    "tallest": _TALL, "taller": _TALL, "tall": _TALL,
    "shortest": _SHORT, "shorter": _SHORT, "short": _SHORT,
    "highest": _HIGH, "higher": _HIGH, "upper": _HIGH, "uppermost": _HIGH, "topmost": _HIGH,
    "elevated": _HIGH, "raised": _HIGH, "high": _HIGH, "low": _LOW,
    "lowest": _LOW, "lower": _LOW, "bottommost": _LOW,
    "longest": _LONG, "longer": _LONG, "long": _LONG, "widest": _LONG, "wider": _LONG,
    "wide": _LONG,
    "narrowest": _NARROW, "narrower": _NARROW, "narrow": _NARROW,
}  # fmt: skip
#: Words after which "to" opens an infinitive ("want to", "something to", "a place to").
INFINITIVE_HEADS = frozenset({"want", "wants", "wanted", "need", "needs", "like", "love",
                              "going", "trying", "try", "able", "have", "has", "something",
                              "somewhere", "anything", "place", "way", "thing", "tool",
                              "object", "where", "how", "what", "ready", "go", "goes",
                              "come"})  # fmt: skip
#: Side words (relative to the observer): word -> "left" | "right" | "middle".
SIDES: dict[str, str] = {
    "left": "left", "leftmost": "left", "rightmost": "right", "right": "right",
    "lefthand": "left", "righthand": "right",
    "middle": "middle", "center": "middle", "centre": "middle", "central": "middle",
}  # fmt: skip
#: Bodily states that point at an affordance ("I am thirsty" -> drink).
STATES: dict[str, str] = {
    "thirsty": "drink", "hungry": "eat", "tired": "sleep", "sleepy": "sleep",
    "cold": "warm up", "chilly": "warm up", "dark": "turn on a light", "bored": "read",
    "dirty": "wash", "wet": "dry", "exhausted": "sleep", "starving": "eat",
    "parched": "drink", "freezing": "warm up", "sweaty": "wash", "hot": "cool down",
    "overheated": "cool down", "boiling": "cool down", "stuffy": "cool down",
    "dim": "turn on a light", "gloomy": "turn on a light",
}  # fmt: skip
#: Words that predicate a state of someone ("I am cold", "it is so dark", "I feel tired").
PREDICATING = frozenset({"am", "is", "are", "feel", "feels", "feeling", "get", "getting",
                         "got", "become", "was", "were"})  # fmt: skip
_DEGREE = frozenset({"so", "very", "too", "really", "quite", "a", "bit", "little", "pretty",
                     "kind", "of", "super", "freaking", "extremely"})  # fmt: skip


#: Words that may follow a state said of someone ("I'm cold | in here", "hot | and tired",
#: "too dark | to read").
_AFTER_STATE = frozenset({"in", "here", "and", "now", "today", "tonight", "but", "so", "out",
                          "outside", "inside", "right", "again", "what", "where", "how",
                          "anything", "is", "there", "can", "could", "any", "all", "lately",
                          "already", "too", "as", "because", "after", "from", "since",
                          "this", "to", "for"})  # fmt: skip
#: Who or what a state is said of: people, and the room they are in.
_STATE_SUBJECTS = frozenset({"i", "we", "you", "he", "she", "they", "it", "everyone",
                             "everybody", "room", "here", "place", "house", "apartment",
                             "kitchen", "bedroom", "bathroom", "office", "baby", "kids",
                             "children", "son", "daughter", "guest", "guests", "feet",
                             "hands", "hair", "throat", "mouth", "body", "back"})  # fmt: skip


def state_at(tokens: tuple[str, ...], i: int) -> str | None:
    """What the bodily state at ``tokens[i]`` calls for (:data:`STATES`), when it is said of
    someone ("I am so cold", "thirsty!"); ``None`` for any other word and for a state word
    said of a thing ("keep my food cold": the fridge is no way to warm up).

    >>> state_at(("i", "am", "so", "cold"), 3), state_at(("keep", "food", "cold"), 2)
    ('warm up', None)
    >>> state_at(("it", "is", "too", "dark", "in", "here"), 3)
    'turn on a light'
    >>> state_at(("this", "is", "dark"), 2), state_at(("a", "dark", "brown", "chair"), 1)
    (None, None)
    """
    want = STATES.get(tokens[i])
    if want is None:
        return None
    following = tokens[i + 1] if i + 1 < len(tokens) else ""
    if following.isalpha() and following not in _AFTER_STATE:
        return None  # an adjective before its noun: "dark brown", "hot water", "cold drink"
    j = i - 1
    while j >= 0 and tokens[j] in _DEGREE:
        j -= 1
    if j < 0:
        return want  # "thirsty!", "so cold"
    if tokens[j] not in PREDICATING:
        return None
    while j >= 0 and tokens[j] in PREDICATING:
        j -= 1
    # said of the speaker, the listener or the room, not of a thing ("this is dark")
    return want if j < 0 or tokens[j] in _STATE_SUBJECTS else None


#: Words that carry no meaning for affordance matching.
ACTION_STOPWORDS = frozenset({
    "where", "what", "which", "can", "could", "would", "should", "i", "me", "my", "we", "you",
    "to", "a", "an", "the", "is", "are", "am", "be", "do", "does", "something", "somewhere",
    "some", "want", "need", "like", "go", "get", "use", "up", "have", "has", "had",
    "down", "it", "there", "here", "for", "of", "one", "anything", "please", "find", "show",
    "let", "us", "let's", "able", "in", "on", "with", "from", "at", "into", "while", "when",
})  # fmt: skip
#: Words a trailing preposition keeps in an affordance phrase ("cook in", "sit on").
PARTICLES = frozenset({"in", "on", "with", "from", "at", "into"})


@dataclass(frozen=True, slots=True)
class Cue:
    """A relation cue found in the tokens: ``kind`` over tokens ``[start, end)``."""

    kind: str
    start: int
    end: int


def find_cue(
    tokens: tuple[str, ...],
    offsets: tuple[int, ...],
    joined: str,
    i: int,
    skip: frozenset[str] = frozenset(),
) -> Cue | None:
    """The longest cue starting at token ``i`` (``offsets``: character start of each token
    in ``joined``) of a kind not in ``skip``, or ``None``."""
    best: Cue | None = None
    best_len = 0
    for kind, pattern in CUES:
        if kind in skip:
            continue
        m = pattern.match(joined, offsets[i])
        if m is None:
            continue
        length = m.end() - m.start()
        if length > best_len:
            end = i + len(m.group(0).split())
            best, best_len = Cue(kind, i, end), length
    return best
